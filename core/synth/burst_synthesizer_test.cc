#include "core/synth/burst_synthesizer.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

#include "core/camera/rolling_shutter.h"
#include "core/io/ground_truth.h"
#include "core/synth/camera_path.h"

namespace dfsm {
namespace {

SynthOptions SmallOptions() {
  SynthOptions options;
  options.width = 320;
  options.height = 240;
  options.frames = 5;
  options.noise_sigma = 0.0;
  options.supersampling = 2;
  return options;
}

// Mean absolute grey difference between the reference and frame i sampled at
// where the ground truth says each reference pixel moved, with `shift` added
// to the predicted position. The contract's geometry holds when the
// unshifted prediction matches far better than a shifted one.
double WarpError(const SynthBurst& burst, int i, double shift) {
  const CameraModel& camera = burst.truth.camera;
  const Pose& pose = burst.truth.poses[i];
  cv::Mat reference, frame;
  cv::cvtColor(burst.frames[burst.manifest.reference], reference, cv::COLOR_BGR2GRAY);
  cv::cvtColor(burst.frames[i], frame, cv::COLOR_BGR2GRAY);
  double sum = 0.0;
  int count = 0;
  for (int v = 20; v < camera.height - 20; v += 3) {
    for (int u = 20; u < camera.width - 20; u += 3) {
      const double depth = burst.truth.depth.at<float>(v, u);
      const Eigen::Vector2d x = camera.PixelToUndistorted(Eigen::Vector2d(u, v));
      const Eigen::Vector3d X = pose.Transform(depth * Eigen::Vector3d(x.x(), x.y(), 1.0));
      const auto pixel = camera.UndistortedToPixel(X.head<2>() / X.z());
      if (!pixel) continue;
      cv::Mat sample;
      cv::getRectSubPix(
          frame, cv::Size(1, 1),
          cv::Point2f(static_cast<float>(pixel->x() + shift), static_cast<float>(pixel->y())),
          sample, CV_32F);
      sum += std::abs(sample.at<float>(0, 0) - reference.at<uchar>(v, u));
      ++count;
    }
  }
  return sum / count;
}

TEST(BurstSynthesizer, FramesFollowTheGroundTruthGeometry) {
  const SynthBurst burst = SynthesizeBurst(SmallOptions());
  ASSERT_EQ(burst.frames.size(), 5u);
  for (int i = 1; i < 5; ++i) {
    const double aligned = WarpError(burst, i, 0.0);
    EXPECT_LT(aligned, 4.0) << "frame " << i;
    EXPECT_LT(aligned * 2.0, WarpError(burst, i, 1.5)) << "frame " << i;
  }
}

// The reference is a choice of the burst, not of the motion: the same frames,
// the truth's poses re-expressed for it (the identity at the reference, every
// pair's relative pose kept) and its own depth, which the frames follow.
TEST(BurstSynthesizer, AnyFrameCanBeTheReference) {
  const SynthBurst first = SynthesizeBurst(SmallOptions());
  SynthOptions options = SmallOptions();
  options.reference = 2;
  const SynthBurst middle = SynthesizeBurst(options);
  ASSERT_EQ(middle.manifest.reference, 2);
  ASSERT_EQ(middle.frames.size(), first.frames.size());
  for (size_t i = 0; i < first.frames.size(); ++i)
    EXPECT_EQ(cv::norm(middle.frames[i], first.frames[i], cv::NORM_INF), 0.0) << "frame " << i;
  EXPECT_TRUE(middle.truth.poses[2].R.isIdentity(0.0));
  EXPECT_TRUE(middle.truth.poses[2].T.isZero(0.0));
  // Frame b's pose seen from frame a: R_b R_a^T, T_b - R_b R_a^T T_a.
  const auto relative = [](const Pose& a, const Pose& b) {
    Pose p;
    p.R = b.R * a.R.transpose();
    p.T = b.T - p.R * a.T;
    return p;
  };
  for (int i = 0; i < 5; ++i) {
    for (int j = 0; j < 5; ++j) {
      const Pose was = relative(first.truth.poses[i], first.truth.poses[j]);
      const Pose is = relative(middle.truth.poses[i], middle.truth.poses[j]);
      EXPECT_LT((is.R - was.R).norm(), 1e-12) << i << " -> " << j;
      EXPECT_LT((is.T - was.T).norm(), 1e-12) << i << " -> " << j;
    }
  }
  EXPECT_GT(cv::norm(middle.truth.depth, first.truth.depth, cv::NORM_L1), 0.0);
  for (int i : {0, 1, 3, 4}) {
    const double aligned = WarpError(middle, i, 0.0);
    EXPECT_LT(aligned, 4.0) << "frame " << i;
    EXPECT_LT(aligned * 2.0, WarpError(middle, i, 1.5)) << "frame " << i;
  }
}

TEST(BurstSynthesizer, MotionMatchesTheRequestedBaselineAndRotation) {
  SynthOptions options = SmallOptions();
  options.baseline = 0.01;
  options.rotation_deg = 0.8;
  const SynthBurst burst = SynthesizeBurst(options);
  double widest = 0.0, largest_rotation = 0.0;
  for (const Pose& a : burst.truth.poses) {
    largest_rotation =
        std::max(largest_rotation, RotationErrorDeg(a.R, Eigen::Matrix3d::Identity()));
    for (const Pose& b : burst.truth.poses)
      widest = std::max(widest, (a.Centre() - b.Centre()).norm());
  }
  EXPECT_NEAR(widest, 0.01, 1e-9);
  EXPECT_NEAR(largest_rotation, 0.8, 1e-6);
  EXPECT_TRUE(burst.truth.poses[0].R.isIdentity());
  EXPECT_EQ(burst.truth.poses[0].T.norm(), 0.0);
}

// Between frames the path is the line between the frame poses (half-way in
// centre and rotation, extrapolated beyond the ends), or the hand's own:
// without the oscillation it curves gently (under half a pixel's angle from
// the line at f = 1000 half-way between frames, the turn never reversing);
// with a tremor of 0.1 deg at a third of a cycle a frame, the turn reverses
// within two frames and leaves the line by more than a pixel (1.5 px for
// this seed). The frame poses are the same either way.
TEST(HandheldPath, FollowsTheLineOrTheHandBetweenFrames) {
  using BetweenFrames = CameraPathOptions::BetweenFrames;
  for (const BetweenFrames between : {BetweenFrames::kLine, BetweenFrames::kHand})
    for (const double oscillation_deg : {0.0, 0.1}) {
      CameraPathOptions options;
      options.rotation_deg = 1.0;
      options.oscillation_deg = oscillation_deg;
      options.between_frames = between;
      options.seed = 4;
      const HandheldPath path(options);
      const std::vector<Pose> frames = path.FramePoses();
      CameraPathOptions line_options = options;
      line_options.between_frames = BetweenFrames::kLine;
      const std::vector<Pose> line_frames = HandheldCameraPath(line_options);
      for (int i = 0; i < options.frames; ++i) {
        EXPECT_EQ(frames[i].R, line_frames[i].R);
        EXPECT_EQ(frames[i].T, line_frames[i].T);
        EXPECT_EQ(frames[i].R, path.At(i).R);
      }
      EXPECT_TRUE(frames[0].R.isIdentity());
      EXPECT_EQ(frames[0].T.norm(), 0.0);
      double largest_px = 0.0, centre_error = 0.0;
      int reversals = 0;
      Eigen::Vector3d previous_step = Eigen::Vector3d::Zero();
      for (int i = 0; i + 1 < options.frames; ++i) {
        const Eigen::Vector3d a = ToPoseParameters(frames[i]).head<3>(),
                              b = ToPoseParameters(frames[i + 1]).head<3>(),
                              half = ToPoseParameters(path.At(i + 0.5)).head<3>();
        largest_px = std::max(largest_px, 1000.0 * (half - 0.5 * (a + b)).norm());
        centre_error = std::max(centre_error, (path.At(i + 0.5).Centre() -
                                               0.5 * (frames[i].Centre() + frames[i + 1].Centre()))
                                                  .norm());
        const Eigen::Vector3d step = b - a;
        if (i > 0 && step.dot(previous_step) < 0.0) ++reversals;
        previous_step = step;
      }
      if (between == BetweenFrames::kLine) {
        EXPECT_LT(largest_px, 1e-3);  // the angle-axis of a composed rotation, not a sum
        EXPECT_LT(centre_error, 1e-12);
        const Pose before = path.At(-0.5);
        EXPECT_LT((before.Centre() - (1.5 * frames[0].Centre() - 0.5 * frames[1].Centre())).norm(),
                  1e-12);
      } else if (oscillation_deg == 0.0) {
        EXPECT_LT(largest_px, 0.5);
        EXPECT_LE(reversals, 1);
      } else {
        EXPECT_GT(largest_px, 1.0);
        EXPECT_GE(reversals, 3);
      }
    }
}

TEST(BurstSynthesizer, DepthCoversTheImageWithSeveralLayers) {
  const SynthBurst burst = SynthesizeBurst(SmallOptions());
  double lowest, highest;
  cv::minMaxLoc(burst.truth.depth, &lowest, &highest);
  EXPECT_GT(lowest, 0.5);
  EXPECT_LT(highest, 10.0);
  EXPECT_GT(highest / lowest, 2.0) << "the scene needs depth contrast";
  EXPECT_EQ(cv::countNonZero(burst.truth.depth), 320 * 240);
}

// The stand-in for the sparse stage's inverse depths samples the truth at
// the centres of the lattice's cells and skips cells without depth.
TEST(BurstSynthesizer, SparseInverseDepthsSampleTheTruthAtCellCentres) {
  const SynthBurst burst = SynthesizeBurst(SmallOptions());
  const std::vector<double> sparse = SparseInverseDepthsFromTruth(burst.truth, 4);
  ASSERT_EQ(sparse.size(), 16u);
  // 320x240 in 4x4 cells of 80x60: centres at (40 + 80 i, 30 + 60 j), row by row.
  EXPECT_DOUBLE_EQ(sparse[0], 1.0 / burst.truth.depth.at<float>(30, 40));
  EXPECT_DOUBLE_EQ(sparse[6], 1.0 / burst.truth.depth.at<float>(90, 200));
  GroundTruth holes = burst.truth;
  holes.depth = burst.truth.depth.clone();
  holes.depth.at<float>(30, 40) = 0.0f;
  EXPECT_EQ(SparseInverseDepthsFromTruth(holes, 4).size(), 15u);
  EXPECT_THROW(SparseInverseDepthsFromTruth(burst.truth, 0), std::invalid_argument);
}

TEST(BurstSynthesizer, IsDeterministicAndSeedDependent) {
  SynthOptions options = SmallOptions();
  options.noise_sigma = 1.0;
  const SynthBurst a = SynthesizeBurst(options), b = SynthesizeBurst(options);
  EXPECT_EQ(cv::norm(a.frames[2], b.frames[2], cv::NORM_INF), 0.0);
  options.seed = 2;
  const SynthBurst c = SynthesizeBurst(options);
  EXPECT_GT(cv::norm(a.frames[2], c.frames[2], cv::NORM_L1), 0.0);
}

TEST(BurstSynthesizer, RoundTripsThroughTheBurstFormat) {
  SynthOptions options = SmallOptions();
  options.color = false;
  options.jpeg_quality = 90;
  const SynthBurst synth = SynthesizeBurst(options);
  const auto dir = std::filesystem::temp_directory_path() / "dfsm_synth_test_burst";
  std::filesystem::remove_all(dir);
  WriteSynthBurst(dir, synth);
  const Burst burst = ReadBurst(dir);
  const Burst in_memory = ToBurst(synth);
  ASSERT_EQ(burst.size(), 5);
  EXPECT_EQ(burst.manifest.pixel_format, "gray8");
  for (int i = 0; i < 5; ++i)
    EXPECT_EQ(cv::norm(burst.gray[i], in_memory.gray[i], cv::NORM_INF), 0);
  const GroundTruth truth = ReadGroundTruth(dir);
  EXPECT_EQ(truth.camera.f, synth.truth.camera.f);
  EXPECT_EQ(cv::norm(truth.depth, synth.truth.depth, cv::NORM_INF), 0.0);
  ASSERT_EQ(truth.poses.size(), 5u);
  EXPECT_TRUE(truth.poses[3].T.isApprox(synth.truth.poses[3].T));
  std::filesystem::remove_all(dir);
}

void ExpectRejectedNaming(const SynthOptions& options, const std::string& name) {
  try {
    SynthesizeBurst(options);
    ADD_FAILURE() << "accepted; expected a rejection naming " << name;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
  }
}

TEST(BurstSynthesizer, RejectsBadOptionsByName) {
  SynthOptions options = SmallOptions();
  options.frames = 2;
  ExpectRejectedNaming(options, "frames");
  options = SmallOptions();
  options.reference = options.frames;  // one past the last frame
  ExpectRejectedNaming(options, "reference");
  EXPECT_THROW(PosesRelativeTo(std::vector<Pose>(3), 3), std::invalid_argument);
  options = SmallOptions();
  options.k1 = -2.0;  // folds the image
  EXPECT_THROW(SynthesizeBurst(options), std::invalid_argument);
}

TEST(BurstSynthesizer, ProceduralTexturesStandInForMissingPhotographs) {
  SynthOptions options = SmallOptions();
  options.texture_dir = "/nonexistent";
  options.frames = 3;
  const SynthBurst burst = SynthesizeBurst(options);
  cv::Scalar mean, stddev;
  cv::meanStdDev(burst.frames[0], mean, stddev);
  EXPECT_GT(stddev[0], 10.0);
  EXPECT_EQ(burst.manifest.source["synthetic"]["textures"][0], "procedural");
}

}  // namespace
}  // namespace dfsm
