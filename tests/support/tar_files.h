// Tars for tests, written by libarchive apart from dfsmd's own writer
// (daemon/service/tar_writer.h), so that hostile names and duplicates can be
// written and the writer under test is not its own judge.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace dfsm::service {

struct TarFile {
  std::string path;  // as written, however hostile
  std::string data;
};

// A tar (pax) of `files`: regular files, mode 0644, mtime 0, in this order.
std::string WriteTar(const std::vector<TarFile>& files);

// Every regular file under `dir`, sorted by path, as TarFiles named relative to it.
std::vector<TarFile> CollectFiles(const std::filesystem::path& dir);

}  // namespace dfsm::service
