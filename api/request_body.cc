#include "api/request_body.h"

#include "api/problem.h"

namespace dfsm::api {
bool HasBody(const httplib::Request& request) {
  return request.has_header("Content-Length") || request.has_header("Transfer-Encoding");
}

bool ReadBody(const httplib::Request& request, const httplib::ContentReader& reader,
              size_t max_bytes, httplib::Response& response,
              const std::function<void(const char*, size_t)>& sink) {
  if (!HasBody(request)) return true;
  if (request.is_multipart_form_data()) {
    SetProblem(response, 415, "unsupported-media-type", "Unsupported body type",
               "multipart/form-data is not accepted; send the body as it is");
    return false;
  }
  size_t received = 0;
  bool too_large = false;
  const bool complete = reader([&](const char* data, size_t length) {
    if (length > max_bytes - received) {
      too_large = true;
      return false;
    }
    received += length;
    sink(data, length);
    return true;
  });
  // httplib sets 413 itself when Content-Length announces too much; a
  // chunked body is caught by the receiver above.
  if (too_large || response.status == 413) {
    response.status = -1;
    SetProblem(response, 413, "body-too-large", "Request body too large",
               "the body exceeds server.max_body_bytes (" + std::to_string(max_bytes) + " bytes)");
    return false;
  }
  if (!complete) {
    SetProblem(response, 400, "unreadable-body", "Request body unreadable",
               "the body ended early or its chunked encoding is malformed");
    return false;
  }
  return true;
}

httplib::Server::HandlerWithContentReader BoundedBody(size_t max_bytes, BodyHandler handler) {
  return [max_bytes, handler = std::move(handler)](const httplib::Request& request,
                                                   httplib::Response& response,
                                                   const httplib::ContentReader& reader) {
    std::string body;
    if (!ReadBody(request, reader, max_bytes, response,
                  [&body](const char* data, size_t length) { body.append(data, length); }))
      return;
    httplib::Request with_body = request;
    with_body.body = std::move(body);
    handler(with_body, response);
  };
}

void RegisterBodyCatchAlls(size_t max_bytes, httplib::Server* server) {
  const auto not_found =
      BoundedBody(max_bytes, [](const httplib::Request& request, httplib::Response& response) {
        SetProblem(response, 404, "not-found", "No such endpoint",
                   request.method + " " + request.path +
                       " is not part of this API; see /api/v1/openapi.json");
      });
  server->Post(".*", not_found);
  server->Delete(".*", not_found);
  server->Put(".*", not_found);
  server->Patch(".*", not_found);
}

}  // namespace dfsm::api
