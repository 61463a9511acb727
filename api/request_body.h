// Request bodies read by dfsmd's own rules instead of httplib 0.11's, which
// (in Debian's compiled library) reads a chunked body without any size limit
// and, for POST or DELETE without Content-Length, waits for more body until
// the connection's read timeout (so `curl -X DELETE` hung for 30 s).
//
// Every route that can carry a body (POST, DELETE, and catch-alls for PUT and
// PATCH) is registered as a content-reader handler through BoundedBody: then
// httplib never reads a body itself. A request with neither Content-Length nor
// Transfer-Encoding has no body (RFC 9112 section 6.3); any body, chunked or
// not, is limited to server.max_body_bytes (413); multipart is refused (415).
#pragma once

#include <httplib.h>

#include <functional>

namespace dfsm::api {

using BodyHandler = std::function<void(const httplib::Request&, httplib::Response&)>;

// Reads the body of `request` (if any) through `reader` into `sink`, at most
// `max_bytes`. Returns false after answering a body over the limit (413),
// unreadable (400) or multipart (415) with problem+json. `sink` may throw;
// the exception propagates.
bool ReadBody(const httplib::Request& request, const httplib::ContentReader& reader,
              size_t max_bytes, httplib::Response& response,
              const std::function<void(const char*, size_t)>& sink);

// Whether the request announces a body (Content-Length or Transfer-Encoding).
bool HasBody(const httplib::Request& request);

// A handler that reads the body (at most `max_bytes`) into a copy of the
// request and passes that to `handler`; a body over the limit, unreadable or
// multipart is answered with problem+json without calling it.
httplib::Server::HandlerWithContentReader BoundedBody(size_t max_bytes, BodyHandler handler);

// Registers POST, DELETE, PUT and PATCH on ".*" as BoundedBody handlers that
// answer 404 (after the body, read and dropped): requests to unknown paths
// must not reach httplib's own unbounded reading either. Call after every
// real route (httplib tries routes in registration order).
void RegisterBodyCatchAlls(size_t max_bytes, httplib::Server* server);

}  // namespace dfsm::api
