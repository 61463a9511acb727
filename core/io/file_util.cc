#include "core/io/file_util.h"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace dfsm {
namespace {

std::runtime_error IoError(const std::string& what, const std::filesystem::path& path) {
  return std::runtime_error(what + " '" + path.string() + "': " + std::strerror(errno));
}

std::atomic<uint64_t> temporary_counter{0};

void WriteAll(const std::filesystem::path& path, const char* data, size_t size, Flush flush) {
  const std::filesystem::path tmp = path.string() + ".tmp." +
                                    std::to_string(static_cast<long>(::getpid())) + "." +
                                    std::to_string(++temporary_counter);
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw IoError("cannot create", tmp);
  size_t written = 0;
  while (written < size) {
    const ssize_t n = ::write(fd, data + written, size - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      const auto error = IoError("cannot write", tmp);
      ::close(fd);
      ::unlink(tmp.c_str());
      throw error;
    }
    written += static_cast<size_t>(n);
  }
  if ((flush == Flush::kEach && ::fsync(fd) != 0) || ::close(fd) != 0) {
    const auto error = IoError("cannot flush", tmp);
    ::unlink(tmp.c_str());
    throw error;
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const auto error = IoError("cannot rename into", path);
    ::unlink(tmp.c_str());
    throw error;
  }
}

}  // namespace

void WriteFileAtomically(const std::filesystem::path& path, const std::string& data, Flush flush) {
  WriteAll(path, data.data(), data.size(), flush);
}

void WriteFileAtomically(const std::filesystem::path& path, const std::vector<unsigned char>& data,
                         Flush flush) {
  WriteAll(path, reinterpret_cast<const char*>(data.data()), data.size(), flush);
}

void SyncFileSystem(const std::filesystem::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw IoError("cannot open", path);
  if (::syncfs(fd) != 0) {
    const auto error = IoError("cannot flush the file system of", path);
    ::close(fd);
    throw error;
  }
  ::close(fd);
}

void SyncDirectory(const std::filesystem::path& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) throw IoError("cannot open", dir);
  if (::fsync(fd) != 0) {
    const auto error = IoError("cannot flush", dir);
    ::close(fd);
    throw error;
  }
  ::close(fd);
}

std::string ReadFileToString(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError("cannot open", path);
  std::ostringstream buffer;
  buffer << in.rdbuf();
  if (in.bad()) throw IoError("cannot read", path);
  return buffer.str();
}

bool IsLexicallyInside(const std::filesystem::path& dir, const std::filesystem::path& path) {
  const std::filesystem::path base = dir.lexically_normal();
  const std::filesystem::path rel = path.lexically_normal().lexically_relative(base);
  if (rel.empty() || rel.is_absolute()) return false;
  const std::string first = rel.begin()->string();
  return first != ".." && first != ".";
}

}  // namespace dfsm
