#include "daemon/service/burst_limits.h"

#include <algorithm>
#include <fstream>
#include <optional>

#include "core/io/file_util.h"
#include "daemon/service/image_size.h"

namespace dfsm::service {
namespace fs = std::filesystem;
namespace {

// Enough for a PNG's IHDR and for a JPEG's header. TurboJPEG reads a JPEG's size only once the data
// reaches the first scan, and phone JPEGs carry up to a few MiB of EXIF and maker notes before it.
constexpr size_t kHeaderBytes = 8 * 1024 * 1024;

std::string ReadPrefix(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::error_code error;
  const uintmax_t size = fs::file_size(path, error);
  std::string bytes(error ? kHeaderBytes : std::min<uintmax_t>(size, kHeaderBytes), '\0');
  in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  bytes.resize(static_cast<size_t>(std::max<std::streamsize>(in.gcount(), 0)));
  return bytes;
}

std::string Dimensions(int64_t width, int64_t height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

// The files a dfsm-burst/1 directory may hold besides its frames
// (../shared/CONTRACT.md, section 2): the manifest and a synthetic burst's
// ground truth.
constexpr const char* kBurstFiles[] = {"manifest.json", "ground_truth.json", "depth_gt.tiff"};

// Every regular file under `burst_dir` is the manifest, a frame it names or
// ground truth: an upload is stored and served back as burst.tar, so it holds
// nothing else.
void CheckOnlyNamedFiles(const fs::path& burst_dir, const BurstManifest& manifest) {
  std::vector<std::string> named(std::begin(kBurstFiles), std::end(kBurstFiles));
  for (const BurstFrameInfo& frame : manifest.frames)
    named.push_back(fs::path(frame.file).lexically_normal().generic_string());
  for (const auto& entry : fs::recursive_directory_iterator(burst_dir)) {
    if (entry.is_directory()) continue;
    const std::string name = entry.path().lexically_relative(burst_dir).generic_string();
    if (std::find(named.begin(), named.end(), name) == named.end()) {
      throw BurstError("'" + name +
                       "' is not a file of the burst: the manifest names no such frame (a burst "
                       "holds manifest.json, its frames and optionally ground_truth.json and "
                       "depth_gt.tiff)");
    }
  }
}

}  // namespace

void CheckUploadedBurst(const fs::path& burst_dir, const BurstManifest& manifest,
                        int requested_frames, const BurstLimits& limits) {
  const std::string origin = "manifest.json";
  const int64_t frames = static_cast<int64_t>(manifest.frames.size());
  if (frames > limits.max_frames) {
    throw BurstError(origin + ": " + std::to_string(frames) +
                     " frames exceed limits.max_burst_frames (" +
                     std::to_string(limits.max_frames) + ")");
  }
  const int64_t pixels = int64_t{manifest.width} * manifest.height;
  if (pixels > limits.max_frame_pixels) {
    throw BurstError(origin + ": " + Dimensions(manifest.width, manifest.height) +
                     " frames exceed limits.max_frame_pixels (" +
                     std::to_string(limits.max_frame_pixels) + " pixels)");
  }
  const int64_t kept = requested_frames > 0 ? std::min<int64_t>(requested_frames, frames) : frames;
  if (kept * pixels > limits.max_burst_pixels) {
    throw BurstError(origin + ": " + std::to_string(kept) + " frames of " +
                     Dimensions(manifest.width, manifest.height) + " are " +
                     std::to_string(kept * pixels) + " pixels, over limits.max_burst_pixels (" +
                     std::to_string(limits.max_burst_pixels) + "); upload fewer frames or ask " +
                     "for fewer with ?frames=");
  }
  for (size_t i = 0; i < manifest.frames.size(); ++i) {
    const std::string& file = manifest.frames[i].file;
    const std::string where = origin + ": frames[" + std::to_string(i) + "] '" + file + "'";
    const fs::path path = burst_dir / file;
    // Links cannot come out of our tar reader, so the lexical check suffices here.
    if (fs::path(file).is_absolute() || !IsLexicallyInside(burst_dir, path)) {
      throw BurstError(where + ": path lies outside the burst directory");
    }
    std::error_code error;
    if (!fs::is_regular_file(path, error)) throw BurstError(where + ": file is missing");
    const std::optional<ImageSize> size = ReadImageSize(ReadPrefix(path));
    if (!size) {
      throw BurstError(where + ": not a PNG or JPEG file (dfsm-burst/1 frames are PNG)");
    }
    if (size->width != manifest.width || size->height != manifest.height) {
      throw BurstError(where + ": the file declares " + Dimensions(size->width, size->height) +
                       ", the manifest says " + Dimensions(manifest.width, manifest.height));
    }
  }
  CheckOnlyNamedFiles(burst_dir, manifest);
}

}  // namespace dfsm::service
