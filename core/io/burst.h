// Reading and writing bursts in the dfsm-burst/1 format (CONTRACT.md section 2).
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/io/png_encode.h"

namespace dfsm {

inline constexpr const char* kBurstFormat = "dfsm-burst/1";

// Thrown for every malformed burst; the message names the problem and the file.
class BurstError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct BurstFrameInfo {
  std::string file;  // relative to the burst directory
  int64_t timestamp_ns = 0;
  int64_t sequence = 0;
};

struct BurstManifest {
  int width = 0;
  int height = 0;
  std::string pixel_format = "gray8";  // "gray8" | "bgr8"
  int reference = 0;
  std::vector<BurstFrameInfo> frames;
  nlohmann::json source;  // optional provenance, written back as given
};

// A burst in memory. `gray` holds every frame as 8-bit single channel (what the
// pipeline works on); `reference_color` keeps the reference frame's colour for
// previews and coloured point clouds (BGR8, or the gray frame when there is none).
struct Burst {
  BurstManifest manifest;
  std::vector<cv::Mat> gray;
  cv::Mat reference_color;
  // Index of each frame in the manifest as stored, when only a window of it was
  // read (ReadBurstOptions::max_frames); empty means 0..size()-1.
  std::vector<int> source_indices;
  // The reference frame's EXIF FocalLengthIn35mmFilm (exif_focal.h), when it
  // is a JPEG that has one.
  std::optional<double> exif_focal_35mm;

  std::vector<int> frame_indices() const;

  int reference() const { return manifest.reference; }
  int width() const { return manifest.width; }
  int height() const { return manifest.height; }
  int size() const { return static_cast<int>(gray.size()); }
};

// Parses and validates manifest.json (not the frames). Throws BurstError.
BurstManifest ParseBurstManifest(const std::string& text, const std::string& origin);
BurstManifest ReadBurstManifest(const std::filesystem::path& burst_dir);
nlohmann::json ToJson(const BurstManifest& manifest);

struct ReadBurstOptions {
  // Keep at most this many frames (0: all): a contiguous window in capture order
  // centred on the reference frame (shifted where it would leave the burst). The
  // reference index is remapped.
  int max_frames = 0;
};

// Reads a burst directory: validates the manifest, checks that every frame lies
// inside the directory, decodes it and checks its size. Throws BurstError.
Burst ReadBurst(const std::filesystem::path& burst_dir, const ReadBurstOptions& options = {});
// The frames `manifest` lists, read from `dir` as ReadBurst reads them;
// errors name `origin` (the listing) and say "frame is WxH, <size_origin> ...".
Burst ReadBurstFrames(const std::filesystem::path& dir, BurstManifest manifest,
                      const ReadBurstOptions& options, const std::string& origin,
                      const std::string& size_origin);

// Converts a decoded frame (8/16-bit, 1/3/4 channels) to 8-bit gray.
cv::Mat ToGray8(const cv::Mat& frame);
// Converts a decoded frame (8/16-bit, 1/3/4 channels) to 8-bit BGR.
cv::Mat ToBgr8(const cv::Mat& frame);

// `manifest` completed for `frames` as WriteBurst stores them: size and pixel
// format from the frames, frames[].file ("frames/NNNNNN.png") and sequence
// filled in where empty. Throws BurstError when the frames do not make a burst
// (fewer than 3, sizes that differ, a count the manifest contradicts).
BurstManifest CompleteManifest(BurstManifest manifest, const std::vector<cv::Mat>& frames);

// How WriteBurst spends CPU.
struct WriteBurstOptions {
  // Frames encoded on every core; false for a background writer that must take
  // only the CPU left over.
  bool in_parallel = true;
  // kStored for a burst written beside the pipeline that runs on it (dfsmd's
  // captures): ~6x less CPU per frame, ~1.5x the bytes of kCompact.
  PngCompression compression = PngCompression::kCompact;
};

// Writes `frames` as PNG (lossless, so a replay is bit-exact) under
// burst_dir/frames/ and the manifest last, each through a temporary file and a
// rename, so a reader never sees a half-written burst. The burst is flushed to
// the disk once at the end (one syncfs, not one fsync per file): it is durable
// when the call returns. manifest.frames[].file is filled in when empty.
// Throws BurstError on an I/O failure.
void WriteBurst(const std::filesystem::path& burst_dir, BurstManifest manifest,
                const std::vector<cv::Mat>& frames, const WriteBurstOptions& options = {});

}  // namespace dfsm
