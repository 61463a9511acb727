#include "api/file_response.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <functional>
#include <memory>
#include <optional>
#include <system_error>
#include <vector>

#include "api/byte_range.h"
#include "api/problem.h"

namespace dfsm::api {
namespace {

// Bytes copied per write: what one request holds in memory beyond httplib's own.
constexpr size_t kPieceBytes = 64 << 10;

// Writes `length` bytes from `offset` of the representation to `sink`; false
// ends the connection (the bytes are gone).
using Reader = std::function<bool(uint64_t offset, size_t length, httplib::DataSink& sink)>;

// The representation of `size` bytes, whole (200) or the one range the gate
// passed on (206, or 416 when it selects no byte).
void Serve(const httplib::Request& request, httplib::Response& response, uint64_t size,
           const char* content_type, Reader reader) {
  response.set_header("Accept-Ranges", "bytes");
  ByteSlice slice{0, size};
  if (request.has_header(kGateRangeField)) {
    const std::optional<ByteRange> range =
        ParseSingleByteRange("bytes=" + request.get_header_value(kGateRangeField));
    const std::optional<ByteSlice> selected = range ? ResolveRange(*range, size) : std::nullopt;
    if (!selected) {
      response.set_header("Content-Range", "bytes */" + std::to_string(size));
      return SetProblem(response, 416, "range-not-satisfiable", "Range not satisfiable",
                        "the range '" + request.get_header_value(kGateRangeField) +
                            "' selects no byte of " + std::to_string(size));
    }
    slice = *selected;
    response.status = 206;
    response.set_header("Content-Range", "bytes " + std::to_string(slice.offset) + "-" +
                                             std::to_string(slice.offset + slice.length - 1) + "/" +
                                             std::to_string(size));
  } else {
    response.status = 200;
  }
  // httplib takes a provider of length 0 for one without a length.
  if (slice.length == 0) return response.set_content("", content_type);
  response.set_content_provider(
      static_cast<size_t>(slice.length), content_type,
      [slice, reader = std::move(reader)](size_t offset, size_t length, httplib::DataSink& sink) {
        return reader(slice.offset + offset, std::min(length, kPieceBytes), sink);
      });
}

// An open file, closed with the response.
struct OpenFile {
  int fd = -1;
  std::vector<char> buffer = std::vector<char>(kPieceBytes);
  ~OpenFile() {
    if (fd >= 0) ::close(fd);
  }
};

}  // namespace

void ServeFile(const httplib::Request& request, httplib::Response& response,
               const std::filesystem::path& path, const char* content_type) {
  auto file = std::make_shared<OpenFile>();
  file->fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  struct stat status {};
  if (file->fd < 0 || ::fstat(file->fd, &status) != 0)
    throw std::system_error(errno, std::generic_category(), "cannot open " + path.string());
  if (!S_ISREG(status.st_mode))
    throw std::system_error(EISDIR, std::generic_category(), path.string() + " is no file");
  Serve(request, response, static_cast<uint64_t>(status.st_size), content_type,
        [file](uint64_t offset, size_t length, httplib::DataSink& sink) {
          ssize_t n;
          do {
            n = ::pread(file->fd, file->buffer.data(), length, static_cast<off_t>(offset));
          } while (n < 0 && errno == EINTR);
          // 0: the file shrank under us; without bytes httplib would ask forever.
          return n > 0 && sink.write(file->buffer.data(), static_cast<size_t>(n));
        });
}

void ServeStaticBytes(const httplib::Request& request, httplib::Response& response,
                      std::string_view bytes, const char* content_type) {
  if (!request.has_header(kGateRangeField)) {
    response.set_header("Accept-Ranges", "bytes");
    return response.set_content(std::string(bytes), content_type);
  }
  Serve(request, response, bytes.size(), content_type,
        [bytes](uint64_t offset, size_t length, httplib::DataSink& sink) {
          // Within the bytes even where httplib applied a Range of its own (a
          // request that did not pass the gate: the fuzzers).
          if (offset >= bytes.size()) return false;
          return sink.write(bytes.data() + offset,
                            std::min<size_t>(length, bytes.size() - static_cast<size_t>(offset)));
        });
}

}  // namespace dfsm::api
