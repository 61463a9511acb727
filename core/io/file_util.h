// Small filesystem helpers shared by the writers of bursts and results.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace dfsm {

// Writes `data` to `path` through `path.tmp.<pid>` + fsync + rename, so readers
// see either the old file or the complete new one. Throws std::runtime_error
// naming the path and errno text.
void WriteFileAtomically(const std::filesystem::path& path, const std::string& data);
void WriteFileAtomically(const std::filesystem::path& path, const std::vector<unsigned char>& data);

// Reads a whole file; throws std::runtime_error naming the path on failure.
std::string ReadFileToString(const std::filesystem::path& path);

// True when `path` (after resolving "." and "..", not symlinks) lies inside `dir`.
bool IsLexicallyInside(const std::filesystem::path& dir, const std::filesystem::path& path);

}  // namespace dfsm
