// Bearer-token authentication of the REST API (RFC 6750). With a token
// configured (server.token_file or the systemd credential, see
// daemon/service/access_token.h) every request needs
// `Authorization: Bearer <token>`, on loopback too, except the probes, the
// API description and the web page's files: GET /healthz, /readyz,
// /api/v1/openapi.json, / and /ui/..., and CORS preflights (browsers send
// those without credentials). Results are data and the camera is a camera, so
// reads are protected like writes.
//
// The connection gate checks it on the request head (request_guard.h), before
// any worker or body byte is spent; Install() adds the same check inside
// httplib for requests that reach it without the gate (the fuzz harness).
#pragma once

#include <httplib.h>

#include <optional>
#include <string>
#include <string_view>

namespace dfsm::api {

// Whether the two strings are equal, in a time that depends on the length of
// `presented` only (SHA-256 of both, compared with CRYPTO_memcmp): no early
// exit at the first differing byte, so response times reveal nothing of
// `expected`.
bool ConstantTimeEquals(std::string_view presented, std::string_view expected);

class BearerAuth {
 public:
  enum class Verdict { kAllowed, kMissing, kNotBearer, kWrongToken };

  // An empty token disables authentication (loopback without a token).
  explicit BearerAuth(std::string token) : token_(std::move(token)) {}

  bool enabled() const { return !token_.empty(); }

  // Requests that never need the token (see above).
  static bool IsPublic(const std::string& method, const std::string& path);

  // Judges an Authorization header value ("" when absent).
  Verdict Check(const std::string& authorization) const;

  // Why a request with this method, path and Authorization value ("" when
  // absent) is refused: the WWW-Authenticate challenge and the problem
  // detail of its 401. nullopt when it is allowed.
  struct Failure {
    std::string challenge;
    std::string detail;
  };
  std::optional<Failure> Refusal(const std::string& method, const std::string& path,
                                 const std::string& authorization) const;

  // Allows the request, or answers it 401 problem+json with
  // WWW-Authenticate and returns false.
  bool Authorize(const httplib::Request& request, httplib::Response& response) const;

  // Installs the check as `server`'s pre-routing and Expect: 100-continue
  // handlers. Does nothing when not enabled().
  void Install(httplib::Server* server) const;

 private:
  std::string token_;
};

}  // namespace dfsm::api
