#include "api/bearer_auth.h"

#include <openssl/crypto.h>
#include <openssl/evp.h>

#include <array>
#include <memory>

#include "api/problem.h"
#include "api/request_head.h"

namespace dfsm::api {

bool ConstantTimeEquals(std::string_view presented, std::string_view expected) {
  // Both sides hashed to 32 bytes, compared by OpenSSL's constant-time
  // CRYPTO_memcmp: the time depends on the length of `presented` only (the
  // hashing), never on where or whether the values differ.
  const auto digest = [](std::string_view text) {
    std::array<unsigned char, EVP_MAX_MD_SIZE> out{};
    unsigned int size = 0;
    EVP_Digest(text.data(), text.size(), out.data(), &size, EVP_sha256(), nullptr);
    return out;
  };
  const auto a = digest(presented);
  const auto b = digest(expected);
  return CRYPTO_memcmp(a.data(), b.data(), 32) == 0;
}

bool BearerAuth::IsPublic(const std::string& method, const std::string& path) {
  if (method == "OPTIONS") return true;
  if (method != "GET" && method != "HEAD") return false;
  // The web page's files carry no data: the page asks for the token itself.
  if (path == "/" || path.rfind("/ui/", 0) == 0) return true;
  return path == "/healthz" || path == "/readyz" || path == "/api/v1/openapi.json";
}

BearerAuth::Verdict BearerAuth::Check(const std::string& authorization) const {
  if (!enabled()) return Verdict::kAllowed;
  if (authorization.empty()) return Verdict::kMissing;
  // "Bearer" SP+ token, the scheme case-insensitive (RFC 7235 section 2.1).
  const size_t space = authorization.find(' ');
  if (space == std::string::npos ||
      !EqualsIgnoringCase(std::string_view(authorization).substr(0, space), "Bearer")) {
    return Verdict::kNotBearer;
  }
  const size_t begin = authorization.find_first_not_of(' ', space);
  const size_t end = authorization.find_last_not_of(" \t");
  if (begin == std::string::npos) return Verdict::kWrongToken;
  const std::string_view presented = std::string_view(authorization).substr(begin, end + 1 - begin);
  return ConstantTimeEquals(presented, token_) ? Verdict::kAllowed : Verdict::kWrongToken;
}

std::optional<BearerAuth::Failure> BearerAuth::Refusal(const std::string& method,
                                                       const std::string& path,
                                                       const std::string& authorization) const {
  if (!enabled() || IsPublic(method, path)) return std::nullopt;
  const Verdict verdict = Check(authorization);
  if (verdict == Verdict::kAllowed) return std::nullopt;
  Failure failure{"Bearer realm=\"dfsmd\"", ""};
  switch (verdict) {
    case Verdict::kMissing:
      failure.detail = method + " " + path +
                       " needs an 'Authorization: Bearer <token>' header: this dfsmd has an "
                       "access token configured (server.token_file or the dfsmd-token credential)";
      break;
    case Verdict::kNotBearer:
      failure.challenge += ", error=\"invalid_request\"";
      failure.detail =
          "the Authorization header must use the Bearer scheme: 'Authorization: Bearer "
          "<token>'";
      break;
    default:
      failure.challenge += ", error=\"invalid_token\"";
      failure.detail = "the bearer token is not the one this dfsmd is configured with";
      break;
  }
  return failure;
}

bool BearerAuth::Authorize(const httplib::Request& request, httplib::Response& response) const {
  const std::optional<Failure> failure =
      Refusal(request.method, request.path, request.get_header_value("Authorization"));
  if (!failure) return true;
  response.set_header("WWW-Authenticate", failure->challenge);
  SetProblem(response, 401, "unauthorized", "Authentication required", failure->detail);
  return false;
}

void BearerAuth::Install(httplib::Server* server) const {
  if (!enabled()) return;
  auto auth = std::make_shared<const BearerAuth>(*this);
  server->set_pre_routing_handler(
      [auth](const httplib::Request& request, httplib::Response& response) {
        return auth->Authorize(request, response) ? httplib::Server::HandlerResponse::Unhandled
                                                  : httplib::Server::HandlerResponse::Handled;
      });
  // A client that waits for "100 Continue" before sending its upload gets the
  // 401 instead, and never sends the body.
  server->set_expect_100_continue_handler(
      [auth](const httplib::Request& request, httplib::Response& response) {
        return auth->Authorize(request, response) ? 100 : response.status;
      });
}

}  // namespace dfsm::api
