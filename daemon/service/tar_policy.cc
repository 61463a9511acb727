#include "daemon/service/tar_policy.h"

#include <sys/stat.h>

#include <algorithm>
#include <sstream>

namespace dfsm::service {

std::string TarPolicy::Admit(const std::string& raw_name, mode_t type, bool hard_link,
                             int64_t size) {
  const std::string where = "tar entry '" + raw_name + "'";
  if (hard_link || S_ISLNK(type)) throw TarError(where + ": links are not allowed");
  if (S_ISCHR(type) || S_ISBLK(type)) throw TarError(where + ": device files are not allowed");
  if (!S_ISREG(type) && !S_ISDIR(type)) throw TarError(where + ": not a regular file or directory");
  if (size > limits_.max_file_bytes) {
    throw TarError(where + ": " + std::to_string(size) + " bytes exceeds the limit of " +
                   std::to_string(limits_.max_file_bytes));
  }
  total_bytes_ += std::max<int64_t>(size, 0);
  if (total_bytes_ > limits_.max_total_bytes) {
    throw TarError(where + ": archive content exceeds the limit of " +
                   std::to_string(limits_.max_total_bytes) + " bytes");
  }
  const std::string name = Normalize(raw_name, where);
  if (name.empty()) return name;
  if (admitted_.count(name)) throw TarError(where + ": duplicate entry");
  if (static_cast<int>(admitted_.size()) >= limits_.max_entries) {
    throw TarError("tar archive has more than " + std::to_string(limits_.max_entries) + " entries");
  }
  // Nothing may lie below a file, whichever of the two comes first.
  for (size_t slash = name.find('/'); slash != std::string::npos;
       slash = name.find('/', slash + 1)) {
    const auto parent = admitted_.find(name.substr(0, slash));
    if (parent != admitted_.end() && !parent->second)
      throw TarError(where + ": lies below the file '" + parent->first + "'");
  }
  const auto below = admitted_.lower_bound(name + "/");
  if (!S_ISDIR(type) && below != admitted_.end() && below->first.rfind(name + "/", 0) == 0)
    throw TarError(where + ": a file, but '" + below->first + "' lies below it");
  admitted_.emplace(name, S_ISDIR(type));
  return name;
}

void TarPolicy::Finish() const {
  if (admitted_.empty()) throw TarError("tar archive is empty");
}

// Relative, no '.', '..' or empty components except a leading "./" and a
// trailing '/', printable characters only.
std::string TarPolicy::Normalize(const std::string& raw, const std::string& where) const {
  if (raw.empty()) throw TarError(where + ": empty file name");
  if (raw[0] == '/') throw TarError(where + ": absolute path is not allowed");
  for (const char c : raw) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f || c == '\\')
      throw TarError(where + ": file name contains a control character or backslash");
  }
  std::string name, part;
  int depth = 0;
  for (std::stringstream stream(raw); std::getline(stream, part, '/');) {
    if (part.empty() || part == ".") continue;
    if (part == "..") throw TarError(where + ": the path leaves the archive ('..')");
    if (++depth > limits_.max_depth) throw TarError(where + ": the path is nested too deeply");
    name += (name.empty() ? "" : "/") + part;
  }
  return name;
}

}  // namespace dfsm::service
