// float32 depth maps as TIFF (CONTRACT.md: depth.tiff, depth_gt.tiff), through
// libtiff: written uncompressed in strips; read from strips or tiles, with any
// compression libtiff knows (files written by OpenCV use deflate).
#pragma once

#include <filesystem>
#include <opencv2/core.hpp>

#include "core/io/file_util.h"

namespace dfsm {

// Writes a CV_32FC1 map atomically (file_util.h: `flush`). Throws
// std::runtime_error naming the path.
void WriteDepthTiff(const std::filesystem::path& path, const cv::Mat& depth,
                    Flush flush = Flush::kEach);
// Reads a single-channel float32 TIFF. Throws std::runtime_error naming the path.
cv::Mat ReadDepthTiff(const std::filesystem::path& path);

}  // namespace dfsm
