#include "api/problem.h"

#include <nlohmann/json.hpp>

namespace dfsm::api {

std::string ProblemBody(int status, const std::string& slug, const std::string& title,
                        const std::string& detail) {
  const nlohmann::json body = {{"type", "urn:dfsm:problem:" + slug},
                               {"title", title},
                               {"status", status},
                               {"detail", detail}};
  // The detail often quotes the request (a path, a query value), which need not
  // be UTF-8: replace bad bytes with U+FFFD instead of throwing, which turned a
  // 404 or 401 into a 500 (found by fuzz/http_fuzzer).
  return body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

void SetProblem(httplib::Response& response, int status, const std::string& slug,
                const std::string& title, const std::string& detail) {
  response.status = status;
  response.set_content(ProblemBody(status, slug, title, detail), kProblemContentType);
}

const char* StatusTitle(int status) {
  switch (status) {
    case 400:
      return "Malformed request";
    case 401:
      return "Authentication required";
    case 403:
      return "Forbidden";
    case 404:
      return "Not found";
    case 405:
      return "Method not allowed";
    case 408:
      return "Request timeout";
    case 413:
      return "Request body too large";
    case 415:
      return "Unsupported media type";
    case 421:
      return "Misdirected request";
    case 431:
      return "Request header fields too large";
    case 501:
      return "Not implemented";
    case 503:
      return "Service unavailable";
    case 505:
      return "HTTP version not supported";
    default:
      return "HTTP error";
  }
}

void SetDefaultProblem(const httplib::Request& request, httplib::Response& response,
                       size_t max_body_bytes) {
  switch (response.status) {
    case 404:
      SetProblem(response, 404, "not-found", "No such endpoint",
                 request.method + " " + request.path + " is not part of this API; see " +
                     "/api/v1/openapi.json");
      return;
    case 405:
      SetProblem(response, 405, "method-not-allowed", "Method not allowed",
                 request.method + " is not supported on " + request.path);
      return;
    case 413:
      SetProblem(
          response, 413, "body-too-large", "Request body too large",
          "the body exceeds server.max_body_bytes (" + std::to_string(max_body_bytes) + " bytes)");
      return;
    case 414:
      SetProblem(response, 414, "uri-too-long", "URI too long", "the request URI is too long");
      return;
    default:
      SetProblem(response, response.status, "http-" + std::to_string(response.status),
                 response.status == 400 ? "Malformed request"
                                        : "HTTP error " + std::to_string(response.status),
                 "the request could not be parsed or handled");
  }
}

std::string HideStateDirectory(std::string detail, const std::filesystem::path& state_dir) {
  std::error_code error;
  for (const std::filesystem::path& form :
       {state_dir, std::filesystem::weakly_canonical(state_dir, error)}) {
    std::string text = form.string();
    while (text.size() > 1 && text.back() == '/') text.pop_back();
    if (text.size() <= 1) continue;  // "/" or "": nothing to hide
    for (size_t at; (at = detail.find(text)) != std::string::npos;)
      detail.replace(at, text.size(), "<state_dir>");
  }
  return detail;
}

}  // namespace dfsm::api
