// Files a user looks at or loads elsewhere, made from a dense depth map:
// depth.tiff (the contract's float32 depth), depth.png (16-bit, scaled),
// confidence.png, preview.png (reference beside colourised inverse depth) and
// points.ply (a coloured, subsampled point cloud).
#pragma once

#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <vector>

#include "core/camera/camera_model.h"
#include "core/export/ply.h"
#include "core/io/file_util.h"

namespace dfsm {

struct DepthExportOptions {
  int max_points = 250000;  // points.ply is subsampled on a regular grid to at most this
  // Flush::kBatched: the caller makes the directory durable at once
  // (SyncFileSystem) instead of one fsync per file.
  Flush flush = Flush::kEach;
  // preview.png (both halves side by side) is scaled down to at most this
  // width: it is for a screen, while depth.tiff and depth.png keep every
  // pixel. At full size (3840x1080) its deflate, ~100-160 ms, would be the
  // slowest file of a 1080p result and the critical path of the writing.
  int preview_max_width = 1920;
};

// depth: CV_32FC1 on the captured grid, 0 = none; confidence: CV_32FC1 in [0, 1]
// (may be empty); reference_color: BGR8 or gray8 reference frame. Encodes and
// writes the files in parallel, each atomically, and returns their
// description for result.json, including the scale of depth.png (depth =
// value * scale).
nlohmann::json WriteDepthOutputs(const std::filesystem::path& out_dir, const cv::Mat& depth,
                                 const cv::Mat& confidence, const cv::Mat& reference_color,
                                 const CameraModel& camera, const DepthExportOptions& options = {});

// The files of WriteDepthOutputs as tasks, for a caller that writes files of
// its own in the same parallel region: a second region would begin only when
// the first one's slowest file is done. The constructor's arguments must
// outlive the tasks; Summary() is valid once they have all run.
class DepthOutputWriter {
 public:
  DepthOutputWriter(std::filesystem::path out_dir, const cv::Mat& depth, const cv::Mat& confidence,
                    const cv::Mat& reference_color, const CameraModel& camera,
                    const DepthExportOptions& options);
  // One task per file, slowest first; each writes its file atomically.
  std::vector<std::function<void()>> Tasks();
  // What WriteDepthOutputs returns.
  nlohmann::json Summary() const;

 private:
  std::filesystem::path out_dir_;
  const cv::Mat& depth_;
  const cv::Mat& confidence_;
  const cv::Mat& reference_color_;
  const CameraModel& camera_;
  DepthExportOptions options_;
  double scale_ = 1.0;
  int stride_ = 1;
  size_t point_count_ = 0;
  double preview_scale_ = 1.0;
};

// The preview image: the reference frame beside its inverse depth in the turbo
// colour map (near = red, far = blue, black = no estimate), each half scaled
// by PreviewScale(depth.cols, max_width).
cv::Mat DepthPreview(const cv::Mat& depth, const cv::Mat& reference_color, int max_width);

// The factor (<= 1) that fits two halves of `width` pixels into `max_width`.
double PreviewScale(int width, int max_width);

// Back-projects every `stride`-th valid pixel through the camera model.
std::vector<ColoredPoint> DepthPointCloud(const cv::Mat& depth, const cv::Mat& reference_color,
                                          const CameraModel& camera, int stride);

}  // namespace dfsm
