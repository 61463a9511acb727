// dfsm's own rules for what an uploaded tar may hold, applied to each entry's
// header before any of its bytes reach the disk: libarchive parses the tar
// (ustar, pax, GNU) but does not decide what is safe to extract.
#pragma once

#include <sys/types.h>

#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>

namespace dfsm::service {

// The message names the entry and the problem.
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

// One archive's entries, in order: plain files and directories only, named
// relative without '..', no duplicates, nothing below a file, within limits.
class TarPolicy {
 public:
  explicit TarPolicy(const TarLimits& limits) : limits_(limits) {}

  // Checks the next entry (`type`: the S_IFMT bits; `hard_link`: it is one)
  // and returns its normalized name ('/'-separated, no '.' or empty parts),
  // "" for the archive's top directory ("./"). Throws TarError.
  std::string Admit(const std::string& raw_name, mode_t type, bool hard_link, int64_t size);
  // Throws TarError when nothing was admitted.
  void Finish() const;

 private:
  std::string Normalize(const std::string& raw, const std::string& where) const;

  const TarLimits limits_;
  std::map<std::string, bool> admitted_;  // name -> is a directory
  int64_t total_bytes_ = 0;
};

}  // namespace dfsm::service
