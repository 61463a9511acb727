#include "fuzz/http_check.h"

#include <cctype>

#include "fuzz/fuzz_check.h"

namespace dfsm::fuzz {

std::string SubstituteFixtures(std::string_view input, const FuzzDaemon& daemon) {
  std::string out;
  out.reserve(input.size() + 64);
  for (size_t i = 0; i < input.size(); ++i) {
    if (i + 3 < input.size() && input[i] == '{' && input[i + 1] == 'J' && input[i + 3] == '}' &&
        input[i + 2] >= '0' && input[i + 2] < '0' + FuzzDaemon::kFixtures) {
      out += daemon.fixture(input[i + 2] - '0');
      i += 3;
    } else {
      out += input[i];
    }
  }
  return out;
}

std::string CheckResponse(const std::string& response) {
  if (response.empty()) return "";  // nothing parseable arrived: the connection is just closed
  size_t start = 0;
  int status = 0;
  for (;;) {
    FUZZ_CHECK(response.compare(start, 9, "HTTP/1.1 ") == 0 && response.size() >= start + 12,
               "no status line in: " + response.substr(start, 200));
    status = std::stoi(response.substr(start + 9, 3));
    if (status != 100) break;
    const size_t end = response.find("\r\n\r\n", start);
    FUZZ_CHECK(end != std::string::npos, "unterminated 100 Continue");
    start = end + 4;
  }
  const size_t headers_end = response.find("\r\n\r\n", start);
  const std::string headers = response.substr(start, headers_end - start);
  FUZZ_CHECK(status != 500, "an exception escaped a handler:\n" + response.substr(start, 2000));
  if (status >= 400) {
    FUZZ_CHECK(headers.find("\r\nContent-Type: application/problem+json") != std::string::npos,
               "an error without problem+json:\n" + response.substr(start, 2000));
  }
  if (headers_end == std::string::npos) return "";
  std::string lower = headers;
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  const size_t length_at = lower.find("\r\ncontent-length: ");
  if (length_at == std::string::npos) return "";
  // The answer to HEAD has a Content-Length and no body. No body of this API
  // (JSON, images, tars) begins with a status line, so one right after the
  // headers is the next answer.
  if (response.compare(headers_end + 4, 9, "HTTP/1.1 ") == 0)
    return response.substr(headers_end + 4);
  const size_t length = std::stoul(lower.substr(length_at + 18));
  const size_t next = headers_end + 4 + length;
  return next < response.size() ? response.substr(next) : "";
}

void CheckResponses(std::string bytes) {
  // A few answers at most: each request of an input gets one.
  for (int i = 0; i < 64 && !bytes.empty(); ++i) bytes = CheckResponse(bytes);
}

}  // namespace dfsm::fuzz
