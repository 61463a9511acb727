#include "core/dense/plane_sweep.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "core/dense/radial_inverse.h"
#include "core/dense/sweep_level.h"

namespace dfsm {
namespace {

// Random frames and poses: what is compared is how costs are aggregated,
// not whether the winners are right.
struct SweepFixture {
  CameraModel camera;
  std::vector<cv::Mat> frames;
  std::vector<Pose> poses;
  cv::Mat reference;

  SweepFixture() {
    camera.width = 96;
    camera.height = 200;  // several bands of rows
    camera.f = 120.0;
    camera.cx = 48.0;
    camera.cy = 100.0;
    cv::RNG rng(5);
    reference.create(camera.height, camera.width, CV_32FC1);
    rng.fill(reference, cv::RNG::UNIFORM, 0.0, 255.0);
    cv::GaussianBlur(reference, reference, cv::Size(), 1.0);
    for (int i = 0; i < 3; ++i) {
      Pose pose;
      pose.T = Eigen::Vector3d(0.01 * (i + 1), -0.005 * i, 0.0);
      poses.push_back(pose);
      cv::Mat frame(reference.size(), CV_32FC1);
      rng.fill(frame, cv::RNG::UNIFORM, 0.0, 255.0);
      cv::GaussianBlur(frame, frame, cv::Size(), 1.0);
      frames.push_back(frame);
    }
  }
};

// The fixture's frames as a full-resolution level, a 32-plane lattice and
// every pixel's window starting at plane 10: what both window sweeps below run on.
struct WindowSweep {
  SweepFixture f;
  RadialInverse radial{f.camera};
  SweepLevel level;
  InverseDepthLattice lattice;
  cv::Mat first{f.reference.size(), CV_32SC1, cv::Scalar(10)};

  WindowSweep() {
    // Burst order: the reference first, then the three frames.
    std::vector<Pose> burst_poses = {Pose{}};
    burst_poses.insert(burst_poses.end(), f.poses.begin(), f.poses.end());
    level = MakeSweepLevel(f.reference, f.frames, SweepPoses::Make(burst_poses, 0, 0.0, f.camera),
                           f.camera, radial, 1);
    lattice.min_inverse_depth = 0.2;
    lattice.max_inverse_depth = 2.0;
    lattice.planes = 32;
  }

  // Seven planes, one lattice plane apart, from `first`.
  PlaneSelection Run(const PhotoCostOptions& options) const {
    return SweepPlaneWindow(level, lattice, first, 7, 1, options);
  }
};

// A level made from frames already downsampled to it (DenseFrames' coarse
// frames) is the level made from the full-size frames, bit for bit.
TEST(MakeSweepLevel, FramesAtTheLevelsSizeGiveTheSameLevel) {
  const SweepFixture f;
  const RadialInverse radial(f.camera);
  std::vector<Pose> burst_poses = {Pose{}};
  burst_poses.insert(burst_poses.end(), f.poses.begin(), f.poses.end());
  const SweepPoses poses = SweepPoses::Make(burst_poses, 0, 0.0, f.camera);
  std::vector<cv::Mat> small;
  for (const cv::Mat& frame : f.frames) small.push_back(DownsampleToLevel(frame, 2));
  const SweepLevel whole = MakeSweepLevel(f.reference, f.frames, poses, f.camera, radial, 2, 2);
  const SweepLevel given =
      MakeSweepLevel(DownsampleToLevel(f.reference, 2), small, poses, f.camera, radial, 2, 2);
  ASSERT_EQ(given.reference.size(), cv::Size(48, 100));
  EXPECT_EQ(cv::countNonZero(whole.reference != given.reference), 0);
  ASSERT_EQ(given.frames.size(), whole.frames.size());
  for (size_t n = 0; n < whole.frames.size(); ++n) {
    ASSERT_EQ(given.frames[n].size(), whole.frames[n].size());
    EXPECT_EQ(cv::countNonZero(whole.frames[n] != given.frames[n]), 0) << "frame " << n;
  }
}

// A wide window wherever the mask is set is exactly the wide window
// everywhere: the streamed bands' halo covers it, and the mask's rows line
// up with the bands' rows.
TEST(SweepPlaneWindow, WideWindowUnderAFullMaskEqualsThatWindowEverywhere) {
  const WindowSweep sweep;
  PhotoCostOptions wide;
  wide.window_radius = 5;
  PhotoCostOptions masked;
  masked.window_radius = 2;
  masked.wide_window_radius = 5;
  masked.wide_window_mask = cv::Mat(sweep.f.reference.size(), CV_8UC1, cv::Scalar(255));
  const PlaneSelection a = sweep.Run(wide);
  const PlaneSelection b = sweep.Run(masked);
  EXPECT_EQ(cv::norm(a.plane, b.plane, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.confidence, b.confidence, cv::NORM_INF), 0.0);
  // An empty mask leaves the narrow window.
  masked.wide_window_mask.setTo(0);
  PhotoCostOptions narrow;
  narrow.window_radius = 2;
  const PlaneSelection c = sweep.Run(narrow);
  const PlaneSelection d = sweep.Run(masked);
  EXPECT_EQ(cv::norm(c.plane, d.plane, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(a.plane, c.plane, cv::NORM_INF), 0.0);  // the windows differ at all
}

// A seed prior that dominates the costs puts every winner on its seed, row
// by row across the streamed bands (the seed's rows line up with the
// bands'), while the edge flags stay the photo-consistency's.
TEST(SweepPlaneWindow, ADominantSeedPriorPutsTheWinnersOnTheirSeeds) {
  const WindowSweep sweep;
  PhotoCostOptions options;
  options.window_radius = 2;
  const PlaneSelection free = sweep.Run(options);
  options.seed_prior.seed.create(sweep.f.reference.size(), CV_32FC1);
  for (int y = 0; y < sweep.f.reference.rows; ++y)
    options.seed_prior.seed.row(y).setTo(10.0f + 1.5f + 0.5f * (y % 7));  // slices 1.5-4.5
  options.seed_prior.weight = 1e4f;
  const PlaneSelection drawn = sweep.Run(options);
  for (int y = 0; y < sweep.f.reference.rows; ++y)
    for (int x = 0; x < sweep.f.reference.cols; ++x) {
      // Near the image's border some planes leave the frames (no cost) and
      // the winner is among the others.
      const bool border =
          x < 20 || y < 20 || x >= sweep.f.reference.cols - 20 || y >= sweep.f.reference.rows - 20;
      if (border) continue;
      const float plane = drawn.plane.at<float>(y, x);
      ASSERT_NEAR(plane, options.seed_prior.seed.at<float>(y, x), 0.01f) << y << ", " << x;
    }
  EXPECT_EQ(cv::norm(drawn.at_edge, free.at_edge, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::countNonZero(free.at_edge), 0);  // random costs often fall to an end
}

}  // namespace
}  // namespace dfsm
