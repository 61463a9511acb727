#include "api/request_head.h"

#include <algorithm>
#include <cctype>
#include <charconv>

namespace dfsm::api {
namespace {

bool IsTokenChar(unsigned char c) {
  return std::isalnum(c) ||
         std::string_view("!#$%&'*+-.^_`|~").find(static_cast<char>(c)) != std::string_view::npos;
}

std::string_view Trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

[[noreturn]] void Malformed(const std::string& detail) {
  throw HeadError(400, "malformed-request", detail);
}

// Splits the head into lines without their CR LF (or lone LF).
std::vector<std::string_view> Lines(std::string_view head) {
  std::vector<std::string_view> lines;
  while (!head.empty()) {
    const size_t newline = head.find('\n');
    std::string_view line = head.substr(0, newline);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    lines.push_back(line);
    if (newline == std::string_view::npos) break;
    head.remove_prefix(newline + 1);
  }
  return lines;
}

void ParseRequestLine(std::string_view line, RequestHead& head) {
  const size_t first = line.find(' ');
  const size_t last = line.rfind(' ');
  if (first == std::string_view::npos || first == last)
    Malformed("the request line is not 'METHOD target HTTP/1.1'");
  const std::string_view method = line.substr(0, first);
  const std::string_view target = line.substr(first + 1, last - first - 1);
  const std::string_view version = line.substr(last + 1);
  if (method.empty() || !std::all_of(method.begin(), method.end(), [](char c) {
        return IsTokenChar(static_cast<unsigned char>(c));
      }))
    Malformed("the request method is not a token");
  if (version == "HTTP/1.1") {
    head.minor_version = 1;
  } else if (version == "HTTP/1.0") {
    head.minor_version = 0;
  } else if (version.substr(0, 5) == "HTTP/") {
    // The HTTP/2 connection preface ("PRI * HTTP/2.0") lands here too: dfsmd
    // speaks HTTP/1.1 only, and says so instead of waiting for more.
    throw HeadError(505, "http-version-not-supported",
                    "dfsmd speaks HTTP/1.0 and HTTP/1.1, not " + std::string(version));
  } else {
    Malformed("the request line does not end in an HTTP version");
  }
  if (target.empty() ||
      !std::all_of(target.begin(), target.end(), [](char c) { return c > 0x20 && c < 0x7f; }))
    Malformed("the request target is empty or holds spaces or control characters");
  if (target.front() != '/' && !(method == "OPTIONS" && target == "*"))
    Malformed("the request target must be an absolute path ('/...')");
  head.method = std::string(method);
  head.target = std::string(target);
  head.path = head.target.substr(0, head.target.find('?'));
}

uint64_t ParseContentLength(std::string_view value) {
  uint64_t length = 0;
  const char* end = value.data() + value.size();
  // Digits only: no sign, no spaces, no list ("5, 5"), no hex, at most 18
  // digits so that the value fits without overflow.
  const auto [at, error] = std::from_chars(value.data(), end, length);
  if (value.empty() || value.size() > 18 || error != std::errc() || at != end ||
      !std::all_of(value.begin(), value.end(), [](char c) { return c >= '0' && c <= '9'; }))
    Malformed("Content-Length '" + std::string(value.substr(0, 40)) +
              "' is not a decimal number of bytes");
  return length;
}

}  // namespace

const std::string* RequestHead::Field(std::string_view name) const {
  for (const auto& [field, value] : fields) {
    if (EqualsIgnoringCase(field, name)) return &value;
  }
  return nullptr;
}

bool RequestHead::WantsClose() const {
  const std::string* connection = Field("Connection");
  if (connection && EqualsIgnoringCase(Trim(*connection), "close")) return true;
  // HTTP/1.0 closes unless it asked to stay.
  return minor_version == 0 && !(connection && EqualsIgnoringCase(Trim(*connection), "keep-alive"));
}

int RequestHead::RemoveFields(std::string_view name) {
  const auto named = [name](const auto& field) { return EqualsIgnoringCase(field.first, name); };
  const int count = static_cast<int>(std::count_if(fields.begin(), fields.end(), named));
  fields.erase(std::remove_if(fields.begin(), fields.end(), named), fields.end());
  return count;
}

std::string RequestHead::Serialize() const {
  std::string text = method + " " + target + " HTTP/1." + std::to_string(minor_version) + "\r\n";
  for (const auto& [name, value] : fields) text += name + ": " + value + "\r\n";
  return text + "\r\n";
}

size_t FindHeadEnd(std::string_view bytes) {
  size_t at = 0;
  // Empty lines before the request line are allowed (and skipped).
  while (at < bytes.size() && (bytes[at] == '\r' || bytes[at] == '\n')) {
    if (bytes[at] == '\r' && at + 1 >= bytes.size()) return std::string_view::npos;
    ++at;
  }
  for (size_t newline = bytes.find('\n', at); newline != std::string_view::npos;
       newline = bytes.find('\n', newline + 1)) {
    // An empty line: "\n\n" or "\n\r\n".
    if (newline + 1 < bytes.size() && bytes[newline + 1] == '\n') return newline + 2;
    if (newline + 2 < bytes.size() && bytes[newline + 1] == '\r' && bytes[newline + 2] == '\n')
      return newline + 3;
  }
  return std::string_view::npos;
}

RequestHead ParseRequestHead(std::string_view text) {
  while (!text.empty() && (text.front() == '\r' || text.front() == '\n')) text.remove_prefix(1);
  std::vector<std::string_view> lines = Lines(text);
  while (!lines.empty() && lines.back().empty()) lines.pop_back();
  if (lines.empty()) Malformed("the request is empty");

  RequestHead head;
  ParseRequestLine(lines.front(), head);
  int hosts = 0;
  int content_lengths = 0;
  int transfer_encodings = 0;
  for (size_t i = 1; i < lines.size(); ++i) {
    const std::string_view line = lines[i];
    if (line.front() == ' ' || line.front() == '\t')
      Malformed("header line " + std::to_string(i) + " is folded (obs-fold is not accepted)");
    const size_t colon = line.find(':');
    if (colon == std::string_view::npos)
      Malformed("header line " + std::to_string(i) + " has no ':'");
    const std::string_view name = line.substr(0, colon);
    if (name.empty() || !std::all_of(name.begin(), name.end(), [](char c) {
          return IsTokenChar(static_cast<unsigned char>(c));
        }))
      Malformed("header line " + std::to_string(i) +
                " has no field name or white space before its ':'");
    const std::string_view value = Trim(line.substr(colon + 1));
    if (std::any_of(value.begin(), value.end(), [](char c) {
          const auto u = static_cast<unsigned char>(c);
          return (u < 0x20 && c != '\t') || u == 0x7f;
        }))
      Malformed("header field '" + std::string(name) + "' holds a control character");
    if (EqualsIgnoringCase(name, "Host")) ++hosts;
    if (EqualsIgnoringCase(name, "Content-Length")) {
      if (++content_lengths > 1) Malformed("more than one Content-Length");
      head.content_length = ParseContentLength(value);
    }
    if (EqualsIgnoringCase(name, "Transfer-Encoding")) {
      if (++transfer_encodings > 1) Malformed("more than one Transfer-Encoding");
      if (!EqualsIgnoringCase(value, "chunked"))
        throw HeadError(501, "transfer-coding-not-implemented",
                        "Transfer-Encoding '" + std::string(value.substr(0, 40)) +
                            "' is not supported; send Content-Length or chunked");
      head.chunked = true;
    }
    head.fields.emplace_back(std::string(name), std::string(value));
  }
  if (head.content_length && head.chunked)
    Malformed("Content-Length together with Transfer-Encoding (ambiguous framing)");
  if (head.chunked && head.minor_version == 0) Malformed("Transfer-Encoding on HTTP/1.0");
  if (hosts > 1) Malformed("more than one Host");
  if (hosts == 0 && head.minor_version == 1) Malformed("an HTTP/1.1 request needs a Host");
  return head;
}

bool EqualsIgnoringCase(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) ==
                  std::tolower(static_cast<unsigned char>(y));
         });
}

std::string HostName(std::string_view host) {
  host = Trim(host);
  std::string_view name;
  if (!host.empty() && host.front() == '[') {
    const size_t close = host.find(']');
    name = close == std::string_view::npos ? host : host.substr(1, close - 1);
  } else {
    name = host.substr(0, host.find(':'));
  }
  std::string lower(name);
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (!lower.empty() && lower.back() == '.') lower.pop_back();  // "localhost."
  return lower;
}

}  // namespace dfsm::api
