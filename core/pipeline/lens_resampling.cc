#include "core/pipeline/lens_resampling.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

namespace dfsm {
namespace {

// The maps are computed at nodes this many pixels apart and interpolated
// between them: a lens's shift is smooth, and over 8 px its bilinear
// interpolation departs from it by hundredths of a pixel at most (0.04 px in
// the corners of TUM's freiburg1 lens, lens_resampling_test), where
// computing every pixel of a 1080p frame cost twice the time.
constexpr int kNodeStep = 8;

// Fixed-point iterations of p <- p + (q - into(p)) find the model pixel p
// that the lens sees at q: `into` is the identity but for a smooth shift
// whose slope is far below 1, so each one cuts the error by that slope.
constexpr int kBackIterations = 6;

// The captured pixels where `lens` sees the undistorted normalized
// coordinates `rays`.
std::vector<cv::Point2d> Project(const OpenCvLens& lens, const std::vector<Eigen::Vector2d>& rays) {
  std::vector<cv::Point3d> points;
  points.reserve(rays.size());
  for (const Eigen::Vector2d& x : rays) points.emplace_back(x.x(), x.y(), 1.0);
  std::vector<cv::Point2d> pixels;
  cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0),
                    cv::Matx33d(lens.fx, 0, lens.cx, 0, lens.fy, lens.cy, 0, 0, 1), lens.distortion,
                    pixels);
  return pixels;
}

// The value of a CV_32FC1 map of nodes at a pixel position, bilinear,
// clamped to the last node.
float AtPixel(const cv::Mat& nodes, double x, double y) {
  const double gx = std::clamp(x / kNodeStep, 0.0, nodes.cols - 1.0);
  const double gy = std::clamp(y / kNodeStep, 0.0, nodes.rows - 1.0);
  const int x0 = std::min(static_cast<int>(gx), nodes.cols - 2);
  const int y0 = std::min(static_cast<int>(gy), nodes.rows - 2);
  const double a = gx - x0, b = gy - y0;
  return static_cast<float>(
      (1 - b) * ((1 - a) * nodes.at<float>(y0, x0) + a * nodes.at<float>(y0, x0 + 1)) +
      b * ((1 - a) * nodes.at<float>(y0 + 1, x0) + a * nodes.at<float>(y0 + 1, x0 + 1)));
}

// cv::remap's fixed-point maps for every pixel of `size`, the position
// bilinear between the nodes: pixel u lies between nodes u / kNodeStep and
// the next, (u % kNodeStep) / kNodeStep of the way. `xy` holds each
// position's integer part (CV_16SC2) and `fraction`, where given, its
// fraction in 1/INTER_TAB_SIZE of a pixel (CV_16UC1), as cv::convertMaps
// writes them; without it the position is rounded to the nearest pixel.
// Written directly, the maps cost half as much as floating-point ones
// converted.
void FixedPointMaps(const cv::Mat& nodes_x, const cv::Mat& nodes_y, cv::Size size, cv::Mat* xy,
                    cv::Mat* fraction) {
  xy->create(size, CV_16SC2);
  if (fraction) fraction->create(size, CV_16UC1);
  cv::parallel_for_(cv::Range(0, size.height), [&](const cv::Range& rows) {
    std::vector<float> row_x(nodes_x.cols), row_y(nodes_x.cols);
    for (int v = rows.start; v < rows.end; ++v) {
      const int j = v / kNodeStep;
      const float b = static_cast<float>(v % kNodeStep) / kNodeStep;
      for (int i = 0; i < nodes_x.cols; ++i) {
        row_x[i] = (1 - b) * nodes_x.at<float>(j, i) + b * nodes_x.at<float>(j + 1, i);
        row_y[i] = (1 - b) * nodes_y.at<float>(j, i) + b * nodes_y.at<float>(j + 1, i);
      }
      int16_t* dst = xy->ptr<int16_t>(v);
      uint16_t* dst_fraction = fraction ? fraction->ptr<uint16_t>(v) : nullptr;
      for (int u = 0; u < size.width; ++u) {
        const int i = u / kNodeStep;
        const float a = static_cast<float>(u % kNodeStep) / kNodeStep;
        const float x = (1 - a) * row_x[i] + a * row_x[i + 1];
        const float y = (1 - a) * row_y[i] + a * row_y[i + 1];
        if (!dst_fraction) {
          dst[2 * u] = cv::saturate_cast<int16_t>(x);
          dst[2 * u + 1] = cv::saturate_cast<int16_t>(y);
          continue;
        }
        const int ix = cv::saturate_cast<int>(x * cv::INTER_TAB_SIZE);
        const int iy = cv::saturate_cast<int>(y * cv::INTER_TAB_SIZE);
        dst[2 * u] = cv::saturate_cast<int16_t>(ix >> cv::INTER_BITS);
        dst[2 * u + 1] = cv::saturate_cast<int16_t>(iy >> cv::INTER_BITS);
        dst_fraction[u] = static_cast<uint16_t>(
            (iy & (cv::INTER_TAB_SIZE - 1)) * cv::INTER_TAB_SIZE + (ix & (cv::INTER_TAB_SIZE - 1)));
      }
    }
  });
}

}  // namespace

LensResampling::LensResampling(const OpenCvLens& lens, const CameraModel& model)
    : size_(model.width, model.height) {
  // Nodes up to one step past the last pixel, so that every pixel lies
  // between two.
  const cv::Size nodes(size_.width / kNodeStep + 2, size_.height / kNodeStep + 2);
  cv::Mat into_x(nodes, CV_32FC1), into_y(nodes, CV_32FC1);
  cv::Mat back_x(nodes, CV_32FC1), back_y(nodes, CV_32FC1);
  std::vector<Eigen::Vector2d> rays;
  rays.reserve(nodes.area());
  for (int j = 0; j < nodes.height; ++j)
    for (int i = 0; i < nodes.width; ++i)
      rays.push_back(model.PixelToUndistorted(Eigen::Vector2d(i * kNodeStep, j * kNodeStep)));
  const std::vector<cv::Point2d> seen = Project(lens, rays);
  double sum_sq = 0.0;
  int inside = 0;  // nodes on the image
  for (int j = 0; j < nodes.height; ++j)
    for (int i = 0; i < nodes.width; ++i) {
      const Eigen::Vector2d p(i * kNodeStep, j * kNodeStep);
      const Eigen::Vector2d q(seen[j * nodes.width + i].x, seen[j * nodes.width + i].y);
      into_x.at<float>(j, i) = static_cast<float>(q.x());
      into_y.at<float>(j, i) = static_cast<float>(q.y());
      if (p.x() < size_.width && p.y() < size_.height) {
        const double shift = (q - p).norm();
        sum_sq += shift * shift;
        max_shift_px_ = std::max(max_shift_px_, shift);
        ++inside;
      }
    }
  rms_shift_px_ = inside > 0 ? std::sqrt(sum_sq / inside) : 0.0;
  for (int j = 0; j < nodes.height; ++j)
    for (int i = 0; i < nodes.width; ++i) {
      const double u = i * kNodeStep, v = j * kNodeStep;
      double x = u, y = v;
      for (int k = 0; k < kBackIterations; ++k) {
        x += u - AtPixel(into_x, x, y);
        y += v - AtPixel(into_y, x, y);
      }
      back_x.at<float>(j, i) = static_cast<float>(x);
      back_y.at<float>(j, i) = static_cast<float>(y);
    }
  // OpenCV's fixed-point maps (1/32 px) remap several times faster than
  // floating-point ones.
  FixedPointMaps(into_x, into_y, size_, &into_xy_, &into_fraction_);
  FixedPointMaps(back_x, back_y, size_, &back_xy_, nullptr);
}

cv::Mat LensResampling::IntoModel(const cv::Mat& captured, int interpolation) const {
  CV_Assert(captured.size() == size_);
  cv::Mat out;
  cv::remap(captured, out, into_xy_,
            interpolation == cv::INTER_NEAREST ? cv::Mat() : into_fraction_, interpolation,
            cv::BORDER_REPLICATE);
  return out;
}

Burst LensResampling::IntoModel(const Burst& burst) const {
  Burst out = burst;
  cv::parallel_for_(cv::Range(0, out.size()), [&](const cv::Range& frames) {
    for (int i = frames.start; i < frames.end; ++i) out.gray[i] = IntoModel(burst.gray[i]);
  });
  if (!out.reference_color.empty()) out.reference_color = IntoModel(burst.reference_color);
  return out;
}

cv::Mat LensResampling::BackToCaptured(const cv::Mat& on_model) const {
  if (on_model.empty()) return on_model;
  CV_Assert(on_model.size() == size_);
  cv::Mat out;
  cv::remap(on_model, out, back_xy_, cv::Mat(), cv::INTER_NEAREST, cv::BORDER_CONSTANT,
            cv::Scalar::all(0));
  return out;
}

}  // namespace dfsm
