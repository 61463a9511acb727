// The limits on an uploaded burst ([limits] in the configuration), checked on
// the extracted files before any frame is decoded, so that a small archive
// cannot make the daemon allocate gigabytes (MemoryMax would kill it).
#pragma once

#include <cstdint>
#include <filesystem>

#include "core/io/burst.h"
#include "daemon/service/config.h"

namespace dfsm::service {

// The [limits] keys that bound a burst, with their defaults.
struct BurstLimits {
  int max_frames = LimitsSection{}.max_burst_frames;
  int64_t max_frame_pixels = LimitsSection{}.max_frame_pixels;
  int64_t max_burst_pixels = LimitsSection{}.max_burst_pixels;
};

// Checks the manifest's frame count and frame size, the pixels of the frames
// the job keeps (`requested_frames`, 0: all), that every frame file is a
// PNG or JPEG whose header declares the manifest's size, and that the
// directory holds no file but the manifest, its frames and ground truth
// (ground_truth.json, depth_gt.tiff). Throws BurstError naming the limit's
// key, or the file and what is wrong with it.
void CheckUploadedBurst(const std::filesystem::path& burst_dir, const BurstManifest& manifest,
                        int requested_frames, const BurstLimits& limits);

}  // namespace dfsm::service
