#include "core/dense/sweep_level.h"

#include <algorithm>
#include <opencv2/imgproc.hpp>

#include "core/camera/rolling_shutter.h"
#include "core/dense/frame_oversampling.h"
#include "core/dense/parallel_rows.h"

namespace dfsm {
namespace {

PlaneHomography ToHomography(const Pose& pose) {
  PlaneHomography warp;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) warp.r[3 * r + c] = static_cast<float>(pose.R(r, c));
    warp.t[r] = static_cast<float>(pose.T(r));
  }
  return warp;
}

}  // namespace

cv::Mat DownsampleToLevel(const cv::Mat& image, int scale) {
  if (scale == 1) return image;
  // INTER_AREA at an integer factor averages scale x scale blocks.
  cv::Mat small;
  cv::resize(image, small, cv::Size(image.cols / scale, image.rows / scale), 0, 0, cv::INTER_AREA);
  return small;
}

SweepPoses SweepPoses::Make(const std::vector<Pose>& poses, int reference, double readout,
                            int height, const std::vector<double>& times) {
  SweepPoses sweep;
  const RowPoses rows(poses, readout, height, times);
  for (int i = 0; i < static_cast<int>(poses.size()); ++i) {
    if (i == reference) continue;
    sweep.frames.push_back(i);
    std::vector<Pose> relative;
    if (readout == 0.0) {
      relative.push_back(poses[i]);
    } else {
      // The sample of reference row y lands within a few pixels of row y in
      // frame i (small motion), so the frame's row time is the reference row's.
      for (int y = 0; y < height; ++y) relative.push_back(rows.Relative(i, y, reference, y));
    }
    sweep.relative.push_back(std::move(relative));
  }
  return sweep;
}

SweepLevel MakeSweepLevel(const cv::Mat& reference, const std::vector<cv::Mat>& frames,
                          const SweepPoses& poses, const CameraModel& camera,
                          const RadialInverse& radial, int scale, int oversample) {
  CV_Assert(scale >= 1 && (oversample == 1 || oversample == 2) &&
            frames.size() == poses.relative.size());
  // Images of the captured size are downsampled here; the level's own size
  // passes as it is (DenseFrames' coarse frames are made so).
  const cv::Size level_size(camera.width / scale, camera.height / scale);
  const auto to_level = [&](const cv::Mat& image) {
    if (image.size() == level_size) return image;
    CV_Assert(image.cols == camera.width && image.rows == camera.height);
    return DownsampleToLevel(image, scale);
  };
  SweepLevel level;
  level.scale = scale;
  level.reference = to_level(reference);
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
  level.centre_x = static_cast<float>(ReducedPixel(camera.cx, scale));
  level.centre_y = static_cast<float>(ReducedPixel(camera.cy, scale));
  level.oversample = oversample;
  level.frames.resize(frames.size());
  cv::parallel_for_(cv::Range(0, static_cast<int>(frames.size())), [&](const cv::Range& range) {
    for (int i = range.start; i < range.end; ++i) {
      const cv::Mat frame = to_level(frames[i]);
      level.frames[i] = oversample == 2 ? OversampleTwice(frame) : frame;
    }
  });
  for (const std::vector<Pose>& rows : poses.relative) {
    std::vector<PlaneHomography> warps;
    if (rows.size() == 1) {
      warps.push_back(ToHomography(rows[0]));
    } else {
      // Level row y is centred on captured row scale * y + (scale - 1) / 2.
      for (int y = 0; y < level.reference.rows; ++y)
        warps.push_back(ToHomography(
            rows[std::min<int>(static_cast<int>(rows.size()) - 1, scale * y + (scale - 1) / 2)]));
    }
    level.warps.push_back(std::move(warps));
  }
  return level;
}

}  // namespace dfsm
