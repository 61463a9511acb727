#include "core/dense/row_projection.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "core/camera/rolling_shutter.h"
#include "core/dense/radial_inverse.h"

namespace dfsm {
namespace {

// A 320x240 burst of five frames, the reference in the middle, under a hand
// tremor of about two degrees (tens of pixels of motion) and a phone's
// readout of 0.6 frame intervals.
struct TremorBurst {
  CameraModel camera;
  std::vector<Pose> poses;
  int reference = 2;

  TremorBurst() {
    camera.width = 320;
    camera.height = 240;
    camera.f = 352.0;
    camera.cx = 161.0;
    camera.cy = 118.5;
    camera.k1 = -0.06;
    camera.k2 = 0.015;
    for (int i = 0; i < 5; ++i) {
      const double s = i - reference;
      const Eigen::Vector3d angle = M_PI / 180.0 * Eigen::Vector3d(0.9 * s, -0.7 * s, 0.5 * s);
      Pose pose;
      if (angle.norm() > 0.0) pose.R = Eigen::AngleAxisd(angle.norm(), angle.normalized()).matrix();
      pose.T = Eigen::Vector3d(0.002 * s, -0.001 * s * s, 0.0005 * s);
      poses.push_back(pose);
    }
  }
};

// Where reference pixel (x, y) of a level (captured row `reference_row` of
// the reference, at inverse depth w) lands in frame `frame`, in the level's
// frame-grid coordinates: the frame row's pose taken at the row the sample
// lands on (`own_row`), found by fixed-point iteration, or at the reference
// row's (the approximation the sweep made before).
Eigen::Vector2d LandsAt(const TremorBurst& b, const RowPoses& rows, const SweepLevel& level,
                        int frame, double x, int reference_row, double y, double w, bool own_row) {
  const double offset = 0.5 * (level.scale - 1);
  const Eigen::Vector2d ray =
      b.camera.PixelToUndistorted({level.scale * x + offset, level.scale * y + offset});
  const Eigen::Vector3d point = ray.homogeneous() / w;
  double v = reference_row;
  Eigen::Vector2d pixel;
  for (int iteration = 0; iteration < (own_row ? 30 : 1); ++iteration) {
    const Pose pose = rows.Relative(frame, v, b.reference, reference_row);
    const Eigen::Vector3d X = pose.R * point + pose.T;
    pixel = *b.camera.UndistortedToPixel(X.head<2>() / X.z());
    v = pixel.y();
  }
  return level.oversample * Eigen::Vector2d(ReducedPixel(pixel.x(), level.scale),
                                            ReducedPixel(pixel.y(), level.scale));
}

bool InsideFrame(const SweepLevel& level, const Eigen::Vector2d& grid) {
  return grid.x() >= 0.0 && grid.y() >= 0.0 && grid.x() <= level.frames[0].cols - 1 &&
         grid.y() <= level.frames[0].rows - 1;
}

struct LevelCase {
  int scale, oversample;
};

class RowProjectionTest : public ::testing::TestWithParam<LevelCase> {};

// Each sample is taken at the pose of the frame row it lands on, within a
// hundredth of a pixel of the exact rolling-shutter geometry, where the
// reference row's pose puts it half a pixel off (0.51-0.55 px).
TEST_P(RowProjectionTest, ASampleTakesThePoseOfTheRowItLandsOn) {
  const LevelCase c = GetParam();
  const TremorBurst b;
  const double readout = 0.6;
  const RadialInverse radial(b.camera);
  const SweepPoses poses = SweepPoses::Make(b.poses, b.reference, readout, b.camera);
  std::vector<cv::Mat> frames;
  for (size_t n = 0; n < poses.frames.size(); ++n)
    frames.push_back(cv::Mat::zeros(b.camera.height, b.camera.width, CV_32FC1));
  const cv::Mat reference = cv::Mat::zeros(b.camera.height, b.camera.width, CV_32FC1);
  const SweepLevel level =
      MakeSweepLevel(reference, frames, poses, b.camera, radial, c.scale, c.oversample);
  ASSERT_TRUE(level.rolling_shutter());
  const RowPoses rows(b.poses, readout, b.camera.height);
  const int cols = level.reference.cols;
  double worst = 0.0, worst_same_row = 0.0;
  int compared = 0;
  for (int y = 0; y < level.reference.rows; y += 7) {
    const int reference_row = c.scale * y + (c.scale - 1) / 2;  // as MakeSweepLevel takes it
    for (const double w : {0.2, 1.0, 3.0}) {
      const std::vector<float> inverse_depths(cols, static_cast<float>(w));
      for (size_t n = 0; n < poses.frames.size(); ++n) {
        RowSamples samples(cols);
        ProjectRow(level, static_cast<int>(n), y, inverse_depths.data(), &samples);
        for (int x = 0; x < cols; x += 5) {
          const int frame = poses.frames[n];
          const Eigen::Vector2d exact =
              LandsAt(b, rows, level, frame, x, reference_row, y, w, /*own_row=*/true);
          const Eigen::Vector2d same_row =
              LandsAt(b, rows, level, frame, x, reference_row, y, w, /*own_row=*/false);
          // Samples beyond the frame are not compared (nor swept).
          if (!samples.usable[x] || !InsideFrame(level, exact)) continue;
          ++compared;
          const double error = (Eigen::Vector2d(samples.px[x], samples.py[x]) - exact).norm();
          worst = std::max(worst, error / level.oversample * c.scale);  // captured pixels
          worst_same_row =
              std::max(worst_same_row, (same_row - exact).norm() / level.oversample * c.scale);
        }
      }
    }
  }
  EXPECT_GT(compared, 1000);
  // Measured 0.013-0.014 px: the image motion per row is linear in the
  // column and the inverse depth (PlaneHomography), and the path's step
  // changes at the frame's middle row, where a sample may land across.
  EXPECT_LT(worst, 0.02);
  EXPECT_GT(worst_same_row, 0.2);
  RecordProperty("worst_px", std::to_string(worst));
  RecordProperty("worst_same_row_px", std::to_string(worst_same_row));
}

// A global shutter: one homography per frame, the frame's own pose.
TEST(RowProjection, AGlobalShutterSamplesWhereTheFramesPoseProjects) {
  const TremorBurst b;
  const RadialInverse radial(b.camera);
  const SweepPoses poses = SweepPoses::Make(b.poses, b.reference, 0.0, b.camera);
  std::vector<cv::Mat> frames(poses.frames.size(),
                              cv::Mat::zeros(b.camera.height, b.camera.width, CV_32FC1));
  const SweepLevel level = MakeSweepLevel(cv::Mat::zeros(b.camera.height, b.camera.width, CV_32FC1),
                                          frames, poses, b.camera, radial, 1, 2);
  ASSERT_FALSE(level.rolling_shutter());
  const RowPoses rows(b.poses, 0.0, b.camera.height);
  const int cols = level.reference.cols;
  const std::vector<float> inverse_depths(cols, 1.0f);
  double worst = 0.0;
  for (int y = 0; y < level.reference.rows; y += 11) {
    RowSamples samples(cols);
    ProjectRow(level, 0, y, inverse_depths.data(), &samples);
    for (int x = 0; x < cols; x += 9) {
      const Eigen::Vector2d exact = LandsAt(b, rows, level, poses.frames[0], x, y, y, 1.0, true);
      if (!samples.usable[x] || !InsideFrame(level, exact)) continue;
      worst = std::max(worst, (Eigen::Vector2d(samples.px[x], samples.py[x]) - exact).norm());
    }
  }
  EXPECT_LT(worst, 0.01);
  RecordProperty("worst_px", std::to_string(worst));
}

INSTANTIATE_TEST_SUITE_P(Levels, RowProjectionTest,
                         ::testing::Values(LevelCase{1, 2}, LevelCase{1, 1}, LevelCase{4, 1},
                                           LevelCase{2, 2}),
                         [](const ::testing::TestParamInfo<LevelCase>& info) {
                           return "scale" + std::to_string(info.param.scale) + "_oversample" +
                                  std::to_string(info.param.oversample);
                         });

}  // namespace
}  // namespace dfsm
