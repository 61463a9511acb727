// A job store directory for one fuzzing process: unique per process (libFuzzer's
// -jobs runs several), removed when the process exits normally.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <string>
#include <system_error>

namespace dfsm::fuzz {

class StateDir {
 public:
  explicit StateDir(const std::string& name)
      : path_(std::filesystem::temp_directory_path() /
              ("dfsm-fuzz-" + name + "-" + std::to_string(::getpid()))) {
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~StateDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  StateDir(const StateDir&) = delete;
  StateDir& operator=(const StateDir&) = delete;

  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

}  // namespace dfsm::fuzz
