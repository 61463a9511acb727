#include "core/dense/sweep_level.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "core/camera/rolling_shutter.h"
#include "core/dense/frame_oversampling.h"
#include "core/parallel/parallel_for.h"

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

// Where the level's reference pixel (x, y) lands at inverse depth w under
// `pose`, on the frames' grid (as ProjectRow maps it, in double).
Eigen::Vector2d GridPosition(const SweepLevel& level, const Pose& pose, int x, int y, double w) {
  const Eigen::Vector3d ray(level.ray_x.at<float>(y, x), level.ray_y.at<float>(y, x), 1.0);
  const Eigen::Vector3d X = pose.R * ray + w * pose.T;
  const Eigen::Vector2d x_u = X.head<2>() / X.z();
  const float r2 = static_cast<float>(x_u.squaredNorm());
  const double scaled = level.focal * level.radial->Ratio(std::min(r2, level.radial->max_r2()));
  return level.oversample *
         Eigen::Vector2d(level.centre_x + scaled * x_u.x(), level.centre_y + scaled * x_u.y());
}

// Level row y's homography against one frame and the image motion per row
// of the frames' grid (a grid row is scale / oversample captured rows), from
// the poses of two frame rows one captured row apart, at the row's first and
// last columns and at inverse depths 0 and 1.
PlaneHomography RowHomography(const SweepLevel& level, const SweepPoses::RowPose& row, int y) {
  PlaneHomography warp = ToHomography(row.at);
  warp.row = static_cast<float>(level.oversample * ReducedPixel(row.row, level.scale));
  const int last = level.reference.cols - 1;
  const double captured_per_grid_row = static_cast<double>(level.scale) / level.oversample;
  const auto motion = [&](int x, double w) -> Eigen::Vector2d {
    return captured_per_grid_row *
           (GridPosition(level, row.next, x, y, w) - GridPosition(level, row.at, x, y, w));
  };
  const Eigen::Vector2d first = motion(0, 0.0), first_near = motion(0, 1.0);
  const Eigen::Vector2d last_far = motion(last, 0.0), last_near = motion(last, 1.0);
  const Eigen::Vector2d g[4] = {first, (last_far - first) / std::max(last, 1), first_near - first,
                                (last_near - first_near - (last_far - first)) / std::max(last, 1)};
  for (int k = 0; k < 4; ++k) {
    warp.gx[k] = static_cast<float>(g[k].x());
    warp.gy[k] = static_cast<float>(g[k].y());
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
                            const CameraModel& camera, const std::vector<double>& times,
                            const AngularVelocities& velocities) {
  SweepPoses sweep;
  const int height = camera.height;
  const RowPoses rows(poses, readout, height, times, velocities);
  for (int i = 0; i < static_cast<int>(poses.size()); ++i) {
    if (i == reference) continue;
    sweep.frames.push_back(i);
    std::vector<RowPose> relative;
    if (readout == 0.0) {
      relative.push_back({poses[i], poses[i], 0.0});
    } else {
      // A sample of reference row y lands on frame row y plus the frame's
      // motion there, up to tens of rows under a tremor of a degree or two
      // (the row's time then differs by readout x rows / height): the poses
      // are taken about the row where the row's centre pixel lands at
      // infinity, and each sample's own row corrects them (ProjectRow).
      for (int y = 0; y < height; ++y) {
        RowPose row;
        row.row = y;
        const Pose same_row = rows.Relative(i, y, reference, y);
        const Eigen::Vector2d x_u = camera.PixelToUndistorted({camera.cx, y});
        const Eigen::Vector3d X = same_row.R * x_u.homogeneous();
        if (X.z() > 0.0)
          if (const std::optional<Eigen::Vector2d> pixel =
                  camera.UndistortedToPixel(X.head<2>() / X.z()))
            row.row = std::clamp(pixel->y(), -0.5 * height, 1.5 * height);
        row.at = rows.Relative(i, row.row, reference, y);
        row.next = rows.Relative(i, row.row + 1.0, reference, y);
        relative.push_back(row);
      }
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
  for (const std::vector<SweepPoses::RowPose>& rows : poses.relative) {
    std::vector<PlaneHomography> warps;
    if (rows.size() == 1) {
      warps.push_back(ToHomography(rows[0].at));
    } else {
      // Level row y is centred on captured row scale * y + (scale - 1) / 2.
      for (int y = 0; y < level.reference.rows; ++y)
        warps.push_back(RowHomography(
            level,
            rows[std::min<int>(static_cast<int>(rows.size()) - 1, scale * y + (scale - 1) / 2)],
            y));
    }
    level.warps.push_back(std::move(warps));
  }
  return level;
}

}  // namespace dfsm
