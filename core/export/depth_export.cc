#include "core/export/depth_export.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/io/depth_tiff.h"
#include "core/io/file_util.h"
#include "core/io/parallel_tasks.h"

namespace dfsm {
namespace {

void WritePng(const std::filesystem::path& path, const cv::Mat& image, Flush flush) {
  std::vector<unsigned char> bytes;
  if (!cv::imencode(".png", image, bytes))
    throw std::runtime_error(path.string() + ": cannot encode PNG");
  WriteFileAtomically(path, bytes, flush);
}

cv::Mat ToBgr(const cv::Mat& image) {
  if (image.channels() == 3) return image;
  cv::Mat bgr;
  cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

}  // namespace

cv::Mat DepthPreview(const cv::Mat& depth, const cv::Mat& reference_color) {
  const cv::Mat valid = depth > 0.0f;
  cv::Mat inverse_depth(depth.size(), CV_32FC1, cv::Scalar(0.0f));
  cv::divide(1.0, depth, inverse_depth);
  inverse_depth.setTo(0.0f, ~valid);
  double lowest = 0.0, highest = 0.0;
  if (cv::countNonZero(valid) > 0)
    cv::minMaxLoc(inverse_depth, &lowest, &highest, nullptr, nullptr, valid);
  cv::Mat normalized;
  const double span = highest > lowest ? highest - lowest : 1.0;
  inverse_depth.convertTo(normalized, CV_8UC1, 255.0 / span, -255.0 * lowest / span);
  cv::Mat coloured;
  cv::applyColorMap(normalized, coloured, cv::COLORMAP_TURBO);
  coloured.setTo(cv::Scalar::all(0), ~valid);
  cv::Mat preview;
  cv::hconcat(ToBgr(reference_color), coloured, preview);
  return preview;
}

std::vector<ColoredPoint> DepthPointCloud(const cv::Mat& depth, const cv::Mat& reference_color,
                                          const CameraModel& camera, int stride) {
  std::vector<ColoredPoint> points;
  const cv::Mat colour = ToBgr(reference_color);
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

nlohmann::json WriteDepthOutputs(const std::filesystem::path& out_dir, const cv::Mat& depth,
                                 const cv::Mat& confidence, const cv::Mat& reference_color,
                                 const CameraModel& camera, const DepthExportOptions& options) {
  CV_Assert(depth.type() == CV_32FC1);
  // depth.png: 16-bit, the largest depth at 65535, 0 = none. The scale is
  // written to result.json, since a small-motion depth has no absolute unit.
  double highest = 0.0;
  cv::minMaxLoc(depth, nullptr, &highest);
  const double scale = highest > 0.0 ? highest / 65535.0 : 1.0;
  const int valid = cv::countNonZero(depth > 0.0f);
  const int stride = std::max(
      1, static_cast<int>(std::ceil(std::sqrt(static_cast<double>(valid) / options.max_points))));
  size_t point_count = 0;

  nlohmann::json files = {
      {"depth.tiff", "float32 depth (Z in the reference camera), 0 = no estimate"},
      {"depth.png", "uint16, depth = value * depth_png_scale, 0 = no estimate"},
      {"preview.png", "reference frame beside inverse depth (turbo: near red, far blue)"},
      {"points.ply", "coloured point cloud, subsampled"}};
  if (!confidence.empty()) files["confidence.png"] = "uint8, confidence * 255";

  // Each file is encoded on its own core (at 1080p the five took ~200 ms one
  // after another, as long as the job's features and rotations together).
  const Flush flush = options.flush;
  const std::vector<std::function<void()>> writers = {
      [&] { WriteDepthTiff(out_dir / "depth.tiff", depth, flush); },
      [&] {
        cv::Mat depth16;
        depth.convertTo(depth16, CV_16UC1, 1.0 / scale);
        depth16.setTo(0, depth <= 0.0f);
        WritePng(out_dir / "depth.png", depth16, flush);
      },
      [&] {
        if (confidence.empty()) return;
        cv::Mat confidence8;
        confidence.convertTo(confidence8, CV_8UC1, 255.0);
        WritePng(out_dir / "confidence.png", confidence8, flush);
      },
      [&] { WritePng(out_dir / "preview.png", DepthPreview(depth, reference_color), flush); },
      [&] {
        const std::vector<ColoredPoint> points =
            DepthPointCloud(depth, reference_color, camera, stride);
        point_count = points.size();
        WritePly(out_dir / "points.ply", points, flush);
      }};
  RunInParallel(writers);
  return {{"files", files},
          {"depth_png_scale", scale},
          {"points", point_count},
          {"points_stride", stride}};
}

}  // namespace dfsm
