#include "core/dense/sweep_level.h"

#include <opencv2/imgproc.hpp>

#include "core/dense/frame_oversampling.h"
#include "core/dense/parallel_rows.h"

namespace dfsm {
namespace {

cv::Mat Downsample(const cv::Mat& image, int scale) {
  if (scale == 1) return image;
  // INTER_AREA at an integer factor averages scale x scale blocks: block x
  // covers captured pixels scale*x .. scale*x + scale - 1, as MakeSweepLevel states.
  cv::Mat small;
  cv::resize(image, small, cv::Size(image.cols / scale, image.rows / scale), 0, 0, cv::INTER_AREA);
  return small;
}

}  // namespace

SweepLevel MakeSweepLevel(const cv::Mat& reference, const std::vector<cv::Mat>& frames,
                          const std::vector<Pose>& poses, const CameraModel& camera,
                          const RadialInverse& radial, int scale, int oversample) {
  CV_Assert(scale >= 1 && (oversample == 1 || oversample == 2) && frames.size() == poses.size());
  SweepLevel level;
  level.scale = scale;
  level.reference = Downsample(reference, scale);
  const double offset = 0.5 * (scale - 1);
  level.ray_x.create(level.reference.size(), CV_32FC1);
  level.ray_y.create(level.reference.size(), CV_32FC1);
  ParallelRows(level.reference.rows, [&](int y) {
    float* rx = level.ray_x.ptr<float>(y);
    float* ry = level.ray_y.ptr<float>(y);
    for (int x = 0; x < level.reference.cols; ++x) {
      double xu, yu;
      PixelToUndistorted(camera.f, camera.k1, camera.k2, camera.cx, camera.cy, scale * x + offset,
                         scale * y + offset, &xu, &yu);
      rx[x] = static_cast<float>(xu);
      ry[x] = static_cast<float>(yu);
    }
  });
  level.radial = &radial;
  level.focal = static_cast<float>(camera.f / scale);
  level.centre_x = static_cast<float>((camera.cx - offset) / scale);
  level.centre_y = static_cast<float>((camera.cy - offset) / scale);
  level.oversample = oversample;
  level.frames.resize(frames.size());
  cv::parallel_for_(cv::Range(0, static_cast<int>(frames.size())), [&](const cv::Range& range) {
    for (int i = range.start; i < range.end; ++i) {
      const cv::Mat frame = Downsample(frames[i], scale);
      level.frames[i] = oversample == 2 ? OversampleTwice(frame) : frame;
    }
  });
  for (size_t i = 0; i < frames.size(); ++i) {
    PlaneHomography warp;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) warp.r[3 * r + c] = static_cast<float>(poses[i].R(r, c));
      warp.t[r] = static_cast<float>(poses[i].T(r));
    }
    level.warps.push_back(warp);
  }
  return level;
}

}  // namespace dfsm
