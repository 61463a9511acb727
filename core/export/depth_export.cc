#include "core/export/depth_export.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <opencv2/imgproc.hpp>

#include "core/io/burst.h"
#include "core/io/depth_tiff.h"
#include "core/io/file_util.h"
#include "core/io/png_encode.h"
#include "core/parallel/parallel_for.h"

namespace dfsm {
namespace {

void WritePng(const std::filesystem::path& path, const cv::Mat& image, Flush flush) {
  std::vector<unsigned char> bytes;
  try {
    bytes = EncodePng(image, PngCompression::kCompact);
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(path.string() + ": " + e.what());
  }
  WriteFileAtomically(path, bytes, flush);
}

}  // namespace

double PreviewScale(int width, int max_width) {
  return std::min(1.0, static_cast<double>(std::max(2, max_width)) / (2.0 * width));
}

cv::Mat DepthPreview(const cv::Mat& full_depth, const cv::Mat& reference_color, int max_width) {
  // The colour range is the full map's, whatever the preview's size.
  double nearest = 0.0, farthest = 0.0;
  const cv::Mat full_valid = full_depth > 0.0f;
  if (cv::countNonZero(full_valid) > 0)
    cv::minMaxLoc(full_depth, &nearest, &farthest, nullptr, nullptr, full_valid);
  const double lowest = farthest > 0.0 ? 1.0 / farthest : 0.0;
  const double highest = nearest > 0.0 ? 1.0 / nearest : 0.0;

  const double scale = PreviewScale(full_depth.cols, max_width);
  cv::Mat depth = full_depth, reference = ToBgr8(reference_color);
  if (scale < 1.0) {
    const cv::Size size(std::max(1, static_cast<int>(std::lround(full_depth.cols * scale))),
                        std::max(1, static_cast<int>(std::lround(full_depth.rows * scale))));
    // Nearest for the depth: an average would blend estimates with the
    // zeros of "no estimate" into depths that were never measured.
    cv::resize(full_depth, depth, size, 0, 0, cv::INTER_NEAREST);
    cv::resize(reference, reference, size, 0, 0, cv::INTER_AREA);
  }
  const cv::Mat valid = depth > 0.0f;
  cv::Mat inverse_depth(depth.size(), CV_32FC1, cv::Scalar(0.0f));
  cv::divide(1.0, depth, inverse_depth);
  inverse_depth.setTo(0.0f, ~valid);
  cv::Mat normalized;
  const double span = highest > lowest ? highest - lowest : 1.0;
  inverse_depth.convertTo(normalized, CV_8UC1, 255.0 / span, -255.0 * lowest / span);
  cv::Mat coloured;
  cv::applyColorMap(normalized, coloured, cv::COLORMAP_TURBO);
  coloured.setTo(cv::Scalar::all(0), ~valid);
  cv::Mat preview;
  cv::hconcat(reference, coloured, preview);
  return preview;
}

std::vector<ColoredPoint> DepthPointCloud(const cv::Mat& depth, const cv::Mat& reference_color,
                                          const CameraModel& camera, int stride) {
  std::vector<ColoredPoint> points;
  const cv::Mat colour = ToBgr8(reference_color);
  for (int v = 0; v < depth.rows; v += stride) {
    const float* row = depth.ptr<float>(v);
    for (int u = 0; u < depth.cols; u += stride) {
      if (!(row[u] > 0.0f)) continue;
      const Eigen::Vector2d x = camera.PixelToUndistorted(Eigen::Vector2d(u, v));
      ColoredPoint point;
      point.position = (row[u] * Eigen::Vector3d(x.x(), x.y(), 1.0)).cast<float>();
      const cv::Vec3b bgr = colour.at<cv::Vec3b>(v, u);
      point.r = bgr[2], point.g = bgr[1], point.b = bgr[0];
      points.push_back(point);
    }
  }
  return points;
}

DepthOutputWriter::DepthOutputWriter(std::filesystem::path out_dir, const cv::Mat& depth,
                                     const cv::Mat& confidence, const cv::Mat& reference_color,
                                     const CameraModel& camera, const DepthExportOptions& options)
    : out_dir_(std::move(out_dir)),
      depth_(depth),
      confidence_(confidence),
      reference_color_(reference_color),
      camera_(camera),
      options_(options) {
  CV_Assert(depth.type() == CV_32FC1);
  // depth.png: 16-bit, the largest depth at 65535, 0 = none. The scale is
  // written to result.json, since a small-motion depth has no absolute unit.
  double highest = 0.0;
  cv::minMaxLoc(depth, nullptr, &highest);
  scale_ = highest > 0.0 ? highest / 65535.0 : 1.0;
  const int valid = cv::countNonZero(depth > 0.0f);
  preview_scale_ = PreviewScale(depth.cols, options.preview_max_width);
  stride_ = std::max(
      1, static_cast<int>(std::ceil(std::sqrt(static_cast<double>(valid) / options.max_points))));
}

std::vector<std::function<void()>> DepthOutputWriter::Tasks() {
  // Slowest first (measured in dfsmd at 1080p: depth.png ~55-65 ms,
  // confidence.png ~30, preview.png ~30 at 1920x540, depth.tiff ~15-30,
  // points.ply ~5), so that the cores run out of work together.
  const Flush flush = options_.flush;
  return {[this, flush] {
            cv::Mat depth16;
            depth_.convertTo(depth16, CV_16UC1, 1.0 / scale_);
            depth16.setTo(0, depth_ <= 0.0f);
            WritePng(out_dir_ / "depth.png", depth16, flush);
          },
          [this, flush] {
            if (confidence_.empty()) return;
            cv::Mat confidence8;
            confidence_.convertTo(confidence8, CV_8UC1, 255.0);
            WritePng(out_dir_ / "confidence.png", confidence8, flush);
          },
          [this, flush] {
            WritePng(out_dir_ / "preview.png",
                     DepthPreview(depth_, reference_color_, options_.preview_max_width), flush);
          },
          [this, flush] {
            const std::vector<ColoredPoint> points =
                DepthPointCloud(depth_, reference_color_, camera_, stride_);
            point_count_ = points.size();
            WritePly(out_dir_ / "points.ply", points, flush);
          },
          [this, flush] { WriteDepthTiff(out_dir_ / "depth.tiff", depth_, flush); }};
}

nlohmann::json DepthOutputWriter::Summary() const {
  nlohmann::json files = {
      {"depth.tiff", "float32 depth (Z in the reference camera), 0 = no estimate"},
      {"depth.png", "uint16, depth = value * depth_png_scale, 0 = no estimate"},
      {"preview.png",
       "reference frame beside inverse depth (turbo: near red, far blue), each half scaled by "
       "preview_scale"},
      {"points.ply", "coloured point cloud, subsampled"}};
  if (!confidence_.empty()) files["confidence.png"] = "uint8, confidence * 255";
  return {{"files", files},
          {"depth_png_scale", scale_},
          {"preview_scale", preview_scale_},
          {"points", point_count_},
          {"points_stride", stride_}};
}

nlohmann::json WriteDepthOutputs(const std::filesystem::path& out_dir, const cv::Mat& depth,
                                 const cv::Mat& confidence, const cv::Mat& reference_color,
                                 const CameraModel& camera, const DepthExportOptions& options) {
  DepthOutputWriter writer(out_dir, depth, confidence, reference_color, camera, options);
  RunInParallel(writer.Tasks());
  return writer.Summary();
}

}  // namespace dfsm
