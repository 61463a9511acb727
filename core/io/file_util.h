// Small filesystem helpers shared by the writers of bursts and results.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace dfsm {

// When a written file reaches the disk. kEach: fsync before the rename, so the
// file is durable when the call returns. kBatched: no fsync; the writer of a
// whole directory (a burst, a result) makes it durable at once with
// SyncFileSystem, one flush instead of one per file.
enum class Flush { kEach, kBatched };

// Writes `data` to `path` through a temporary name unique to this write
// (`path.tmp.<pid>.<n>`) and a rename, so readers see either the old file or
// the complete new one, and two writers of one path never share a temporary.
// Throws std::runtime_error naming the path and errno text.
void WriteFileAtomically(const std::filesystem::path& path, const std::string& data,
                         Flush flush = Flush::kEach);
void WriteFileAtomically(const std::filesystem::path& path, const std::vector<unsigned char>& data,
                         Flush flush = Flush::kEach);

// syncfs(2) on the file system that holds `path`: every file written with
// Flush::kBatched, and every directory entry made by a create or a rename,
// reaches the disk. Throws std::runtime_error naming the path.
void SyncFileSystem(const std::filesystem::path& path);

// fsync(2) on a directory: its entries (a rename into it, say) are durable.
// Throws std::runtime_error naming the directory.
void SyncDirectory(const std::filesystem::path& dir);

// Reads a whole file; throws std::runtime_error naming the path on failure.
std::string ReadFileToString(const std::filesystem::path& path);

// True when `path` (after resolving "." and "..", not symlinks) lies inside `dir`.
bool IsLexicallyInside(const std::filesystem::path& dir, const std::filesystem::path& path);

}  // namespace dfsm
