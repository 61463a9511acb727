// A small reader and writer of POSIX ustar archives, enough for bursts: plain
// files and directories only. The reader trusts nothing in the archive: every
// header's checksum, magic, size and name is checked, and links, device files,
// absolute names, '..' and anything past the limits are rejected by name.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace dfsm::service {

// The message names the entry (or the byte offset) and the problem.
class TarError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct TarLimits {
  int max_entries = 4096;
  int64_t max_file_bytes = 256LL << 20;
  int64_t max_total_bytes = 1LL << 30;
  int max_depth = 8;  // path components
};

struct TarEntry {
  std::string path;  // normalized, relative, '/'-separated, no trailing '/'
  bool is_directory = false;
  std::string_view data;  // into the archive; empty for directories
};

// Parses `archive` (which must outlive the entries). Throws TarError.
std::vector<TarEntry> ReadTar(std::string_view archive, const TarLimits& limits = {});

// Writes the entries' files under `dir` (which must exist and be empty),
// creating directories as needed. Entries come from ReadTar, so names are safe.
// Files are written in pieces, in archive order; after each piece
// `consumed(end)`, when given, learns that the archive's bytes before `end`
// are no longer needed.
void ExtractTar(const std::vector<TarEntry>& entries, const std::filesystem::path& dir,
                const std::function<void(const char* end)>& consumed = nullptr);

struct TarFile {
  std::string path;  // relative, at most 255 characters
  std::string data;
};

// A ustar archive of `files` (regular files, mode 0644, mtime `mtime`).
std::string WriteTar(const std::vector<TarFile>& files, int64_t mtime = 0);

// The tar WriteTar(CollectFiles(dir)) would make, read piece by piece from
// the files themselves: a download of a burst takes a buffer, not the burst's
// size in memory (four concurrent 245 MiB downloads took +2.9 GB).
class TarStream {
 public:
  // Lists the regular files under `dir`. Throws TarError for a name ustar
  // cannot hold, std::filesystem::filesystem_error when `dir` is unreadable.
  explicit TarStream(const std::filesystem::path& dir);
  int64_t size() const { return size_; }
  // Bytes [offset, offset + length) of the archive (fewer at its end). Throws
  // TarError when a file shrank since the listing.
  std::string Read(int64_t offset, size_t length) const;

 private:
  struct Member {
    std::string name;
    std::filesystem::path file;
    int64_t size;
    int64_t offset;  // of its header in the archive
  };
  std::vector<Member> members_;
  int64_t size_ = 0;
};

// Every regular file under `dir`, sorted by path, as TarFiles named relative to it.
std::vector<TarFile> CollectFiles(const std::filesystem::path& dir);

}  // namespace dfsm::service
