// RAII removal of a staging directory (JobStore::NewStagingDir) that did not
// become part of a job: whatever was moved out of it into the job stays, the
// rest goes, on every path out of the scope, an exception's included.
#pragma once

#include <filesystem>
#include <utility>

namespace dfsm::service {

class StagingGuard {
 public:
  // An empty `dir` guards nothing.
  explicit StagingGuard(std::filesystem::path dir = {}) : dir_(std::move(dir)) {}
  ~StagingGuard();  // removes dir, never throws
  StagingGuard(const StagingGuard&) = delete;
  StagingGuard& operator=(const StagingGuard&) = delete;

  const std::filesystem::path& dir() const { return dir_; }

 private:
  std::filesystem::path dir_;
};

}  // namespace dfsm::service
