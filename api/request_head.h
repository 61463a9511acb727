// The head of an HTTP/1.x request (request line and header fields), parsed by
// dfsmd's own strict rules before cpp-httplib sees the request.
//
// httplib 0.11 buffers a line until its newline, accepts two different
// Content-Lengths, Content-Length beside chunked, "Content-Length: abc" and
// header lines without a colon: behind a proxy that is request smuggling, and
// in front of one it is unbounded memory. The connection gate
// (connection_gate.h) reads at most server.max_head_bytes, finds the end of
// the head with FindHeadEnd and refuses anything ParseRequestHead refuses, so
// httplib only ever parses a head that is complete, bounded and unambiguous.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace dfsm::api {

// A head that cannot be served. `status` is the answer (400, 501, 505);
// `slug` and the message become the problem+json type and detail.
class HeadError : public std::runtime_error {
 public:
  HeadError(int status, std::string slug, const std::string& detail)
      : std::runtime_error(detail), status_(status), slug_(std::move(slug)) {}
  int status() const { return status_; }
  const std::string& slug() const { return slug_; }

 private:
  int status_;
  std::string slug_;
};

struct RequestHead {
  std::string method;     // "GET"
  std::string target;     // "/api/v1/jobs?limit=5"
  std::string path;       // target without the query: "/api/v1/jobs"
  int minor_version = 1;  // HTTP/1.<minor_version>
  std::vector<std::pair<std::string, std::string>> fields;  // in order, values trimmed
  // Framing: at most one of these (a head with both is refused).
  std::optional<uint64_t> content_length;
  bool chunked = false;

  // The first field named `name` (case-insensitive), or nullptr.
  const std::string* Field(std::string_view name) const;
  // Whether the body has any bytes (or may have: chunked).
  bool HasBody() const { return chunked || content_length.value_or(0) > 0; }
  // Whether the client asked for the connection to end after this request.
  bool WantsClose() const;
  // Removes every field named `name` (case-insensitive); returns how many.
  int RemoveFields(std::string_view name);
  // The head as HTTP/1.1 bytes: request line and fields ended by CR LF, then
  // the empty line. What the gate hands on after changing fields.
  std::string Serialize() const;
};

// The length of the head at the start of `bytes` including its terminating
// empty line ("\r\n\r\n", or "\n\n" from lax clients), or npos when `bytes`
// does not hold a complete head yet. Empty lines before the request line
// (RFC 9112 section 2.2) count as part of the head.
size_t FindHeadEnd(std::string_view bytes);

// Parses a complete head (as delimited by FindHeadEnd). Throws HeadError:
//   400 for a malformed request line or field line (no colon, white space
//       before the colon, obs-fold, control characters), a missing or second
//       Host on HTTP/1.1, a Content-Length that is not one plain decimal
//       number, two Content-Lengths, Content-Length with Transfer-Encoding,
//       Transfer-Encoding on HTTP/1.0;
//   501 for a transfer coding other than "chunked";
//   505 for any version but HTTP/1.0 and 1.1, including the HTTP/2 preface
//       "PRI * HTTP/2.0".
RequestHead ParseRequestHead(std::string_view head);

// ASCII case-insensitive equality: field names, connection options, transfer
// codings and auth schemes are case-insensitive (RFC 9110 sections 5.1, 7.6.1,
// 11.1).
bool EqualsIgnoringCase(std::string_view a, std::string_view b);

// The host part of a Host field value: "[::1]:8080" -> "::1",
// "Example.org:80" -> "example.org" (lower-cased).
std::string HostName(std::string_view host_field);

}  // namespace dfsm::api
