// Extracts an uploaded tar (ustar, pax or GNU) with libarchive under
// TarPolicy's rules as it is read. Compressed tars are refused by name, not
// decompressed, and sparse files are refused: no upload expands beyond its
// bytes, and every file holds exactly the bytes its header declares.
#pragma once

#include <filesystem>
#include <functional>
#include <optional>
#include <string_view>

#include "daemon/service/tar_policy.h"

namespace dfsm::service {

// Fills `buffer` with up to `size` bytes of the archive, 0 at its end. May
// throw: the extraction then fails with the message as a TarError.
using TarSource = std::function<size_t(char* buffer, size_t size)>;

// Writes the archive's files and directories under `dir` (existing, empty).
// Throws TarError for an archive refused, damaged, truncated or compressed;
// std::system_error when the disk refuses. `dir` keeps what was written.
void ExtractTar(const TarSource& source, const std::filesystem::path& dir, const TarLimits& limits);
void ExtractTar(std::string_view archive, const std::filesystem::path& dir,
                const TarLimits& limits);

// The burst an extracted archive holds: its top level, or its single
// top-level directory, whichever has the manifest.json. nullopt where neither.
std::optional<std::filesystem::path> BurstRootOf(const std::filesystem::path& extracted);

}  // namespace dfsm::service
