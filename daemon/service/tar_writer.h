// burst.tar, written by libarchive in the pax format: plain ustar headers
// where they suffice, a pax header for a long name; any tar reader reads it.
#pragma once

#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "daemon/service/tar_policy.h"

struct archive;  // libarchive's

namespace dfsm::service {

// A tar of the regular files under `dir` (sorted by path, mode 0644, mtime
// 0), made piece by piece as it is read: a download of a burst takes a
// buffer, not the burst's size in memory (four concurrent 245 MiB downloads
// took +2.9 GB when it did).
class DirectoryTar {
 public:
  // Lists the files. Throws std::filesystem::filesystem_error.
  explicit DirectoryTar(const std::filesystem::path& dir);

  // The archive's next bytes; empty after its end. Throws TarError when a
  // file shrank or vanished since the listing.
  std::string Next();

 private:
  void Step();

  std::vector<std::pair<std::string, std::filesystem::path>> files_;  // name, file
  size_t next_file_ = 0;
  std::ifstream file_;  // the one being written
  int64_t left_ = 0;    // of its data
  bool closed_ = false;
  std::string out_;  // written by libarchive since the last Next
  std::unique_ptr<archive, int (*)(archive*)> archive_;
};

}  // namespace dfsm::service
