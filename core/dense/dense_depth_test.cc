#include "core/dense/dense_depth.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "core/pipeline/evaluation.h"

namespace dfsm {
namespace {

// A burst of one slanted, randomly textured plane n . X = 1 (reference
// coordinates), rendered by ray casting through the contract's camera model:
// no occlusion, and a depth that changes across the image, so a shifted depth
// map shows up as a bias along the slant.
struct PlaneScene {
  Burst burst;
  CameraModel camera;
  std::vector<Pose> poses;
  Eigen::Vector3d normal;  // the plane n . X = 1
  cv::Mat depth;           // CV_32FC1, ground truth of the reference
  std::vector<double> sparse_inverse_depths;

  double InverseDepth(const Eigen::Vector2d& pixel) const {
    const Eigen::Vector2d x = camera.PixelToUndistorted(pixel);
    return normal.dot(Eigen::Vector3d(x.x(), x.y(), 1.0));  // n . (x Z) = 1
  }
};

PlaneScene RenderPlaneScene(const Eigen::Vector3d& normal, int frames) {
  PlaneScene scene;
  scene.normal = normal;
  CameraModel& camera = scene.camera;
  camera.width = 640;
  camera.height = 480;
  camera.f = 704.0;
  camera.cx = 320.0;
  camera.cy = 240.0;
  camera.k1 = -0.06;
  camera.k2 = 0.015;
  cv::RNG rng(11);
  // Texture: band-limited noise, ~1.5 texels per image pixel at 1.5 m.
  cv::Mat texture(1400, 1400, CV_32FC1);
  rng.fill(texture, cv::RNG::UNIFORM, 0.0, 255.0);
  cv::GaussianBlur(texture, texture, cv::Size(), 1.2);
  cv::normalize(texture, texture, 20.0, 235.0, cv::NORM_MINMAX);
  const double texels_per_metre = 500.0;
  // Poses spread on both sides of the reference (8 mm, 0.3 degrees).
  for (int i = 0; i < frames; ++i) {
    Pose pose;
    if (i > 0) {
      const Eigen::Vector3d angles(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0),
                                   rng.uniform(-1.0, 1.0));
      pose.R = Eigen::AngleAxisd(0.3 * M_PI / 180.0 * angles.norm(), angles.normalized())
                   .toRotationMatrix();
      const double a = 2.0 * M_PI * i / (frames - 1);
      pose.T = Eigen::Vector3d(0.004 * std::cos(a), 0.004 * std::sin(a), rng.uniform(-1e-3, 1e-3));
    }
    scene.poses.push_back(pose);
  }
  scene.burst.manifest.width = camera.width;
  scene.burst.manifest.height = camera.height;
  for (int i = 0; i < frames; ++i) {
    const Eigen::Matrix3d Rt = scene.poses[i].R.transpose();
    const Eigen::Vector3d centre = scene.poses[i].Centre();
    cv::Mat frame(camera.height, camera.width, CV_8UC1);
    for (int v = 0; v < camera.height; ++v)
      for (int u = 0; u < camera.width; ++u) {
        double value = 0.0;
        for (const double dv : {-0.25, 0.25})
          for (const double du : {-0.25, 0.25}) {
            const Eigen::Vector2d x = camera.PixelToUndistorted({u + du, v + dv});
            const Eigen::Vector3d ray = Rt * Eigen::Vector3d(x.x(), x.y(), 1.0);
            const double t = (1.0 - normal.dot(centre)) / normal.dot(ray);
            const Eigen::Vector3d X = centre + t * ray;
            const double tx = 700.0 + texels_per_metre * X.x();
            const double ty = 700.0 + texels_per_metre * X.y();
            const int x0 = static_cast<int>(tx), y0 = static_cast<int>(ty);
            const double ax = tx - x0, ay = ty - y0;
            const float* row0 = texture.ptr<float>(y0) + x0;
            const float* row1 = texture.ptr<float>(y0 + 1) + x0;
            value += 0.25 * ((1 - ay) * ((1 - ax) * row0[0] + ax * row0[1]) +
                             ay * ((1 - ax) * row1[0] + ax * row1[1]));
          }
        frame.at<uchar>(v, u) = cv::saturate_cast<uchar>(value + rng.gaussian(1.0));
      }
    scene.burst.gray.push_back(frame);
    scene.burst.manifest.frames.push_back({});
  }
  scene.burst.reference_color = scene.burst.gray[0];
  scene.depth.create(camera.height, camera.width, CV_32FC1);
  for (int v = 0; v < camera.height; ++v)
    for (int u = 0; u < camera.width; ++u)
      scene.depth.at<float>(v, u) = static_cast<float>(1.0 / scene.InverseDepth({u, v}));
  for (int v = 20; v < camera.height; v += 110)
    for (int u = 20; u < camera.width; u += 150)
      scene.sparse_inverse_depths.push_back(scene.InverseDepth({u, v}));
  return scene;
}

// Mean over valid pixels of (estimated - true) inverse depth, with the truth
// read `shift` pixels away: zero at the shift the estimate is displaced by.
double MeanInverseDepthBias(const PlaneScene& scene, const cv::Mat& depth, cv::Point shift) {
  double sum = 0.0;
  int count = 0;
  for (int v = 8; v < depth.rows - 8; ++v)
    for (int u = 8; u < depth.cols - 8; ++u) {
      const float d = depth.at<float>(v, u);
      if (d <= 0.0f) continue;
      sum += 1.0 / d - scene.InverseDepth({u + shift.x, v + shift.y});
      ++count;
    }
  return sum / std::max(count, 1);
}

// The best integer shift of the estimate against the truth, searched along
// the plane's slant direction within +-3 pixels.
cv::Point BestShift(const PlaneScene& scene, const cv::Mat& depth, cv::Point direction) {
  cv::Point best(0, 0);
  double best_bias = std::abs(MeanInverseDepthBias(scene, depth, best));
  for (int s = -3; s <= 3; ++s) {
    const double bias = std::abs(MeanInverseDepthBias(scene, depth, s * direction));
    if (bias < best_bias) best_bias = bias, best = s * direction;
  }
  return best;
}

// Pixels the depth map is displaced by along `direction`, read from its mean
// inverse-depth bias: a displacement by s reads s on a plane and on its
// mirror image, a relative bias of the inverse depth reads with opposite signs.
double ApparentDisplacement(const PlaneScene& scene, const cv::Mat& depth, cv::Point direction) {
  // Inverse-depth change per pixel along the slant, from the truth itself.
  const double per_pixel =
      scene.InverseDepth(Eigen::Vector2d(320 + direction.x, 240 + direction.y)) -
      scene.InverseDepth({320, 240});
  return MeanInverseDepthBias(scene, depth, {0, 0}) / per_pixel;
}

class DenseDepthPlaneTest : public ::testing::TestWithParam<int> {};

// A plane slanted along x (param 0) or y (param 1), and its mirror image:
// the depth is accurate, dense, in the poses' scale, and does not drift. The
// best integer shift against the truth is (0, 0); the mean of the two planes'
// apparent displacements is what the map is displaced by (a grid convention
// error would show as >= 0.5 pixel), half their difference a bias of the
// inverse depth that is the same on both.
TEST_P(DenseDepthPlaneTest, AccurateAndAlignedWithTheCapturedGrid) {
  const bool along_x = GetParam() == 0;
  const cv::Point direction = along_x ? cv::Point(1, 0) : cv::Point(0, 1);
  double displacement[2];
  for (const int mirror : {0, 1}) {
    const double sign = mirror ? -1.0 : 1.0;
    const Eigen::Vector3d normal = along_x ? Eigen::Vector3d(-0.5 * sign, 0.0, 0.6)   // Z 1.2-2.4
                                           : Eigen::Vector3d(0.0, -0.6 * sign, 0.6);  // 1.2-2.5
    SCOPED_TRACE(mirror ? "mirrored" : "plane");
    const PlaneScene scene = RenderPlaneScene(normal, 6);
    const DenseDepth dense =
        ComputeDenseDepth(scene.burst, scene.camera, scene.poses, scene.sparse_inverse_depths);
    ASSERT_EQ(dense.depth.type(), CV_32FC1);
    ASSERT_EQ(dense.depth.size(), cv::Size(640, 480));
    EXPECT_EQ(dense.planes, 128);
    EXPECT_GT(dense.valid_fraction, 0.9);
    // result.json's dense timings name the stages, in order (what the page and
    // the benchmarks read).
    std::vector<std::string> stages;
    for (const auto& [stage, ms] : dense.timings_ms) stages.push_back(stage);
    ASSERT_GE(stages.size(), 3u);
    EXPECT_EQ(stages.front(), "prepare");
    EXPECT_EQ(stages[1], "coarse_sweep");
    EXPECT_NE(std::find(stages.begin(), stages.end(), "refine"), stages.end());
    // Measured is exactly confidence >= min_confidence (result.json says so).
    EXPECT_EQ(dense.min_confidence, DenseOptions().min_confidence);
    EXPECT_EQ(cv::countNonZero((dense.depth > 0.0f) != (dense.confidence >= dense.min_confidence)),
              0);

    const DepthEvaluation evaluation =
        EvaluateDepth(dense.depth, scene.depth, TexturedMask(scene.burst.gray[0]));
    EXPECT_NEAR(evaluation.scale, 1.0, 0.01);  // true poses: no scale to absorb
    EXPECT_LT(evaluation.abs_rel, 0.02);
    EXPECT_GT(evaluation.within_5_percent, 0.95);
    EXPECT_GT(evaluation.coverage, 0.9);
    EXPECT_EQ(BestShift(scene, dense.depth, direction), cv::Point(0, 0));
    displacement[mirror] = ApparentDisplacement(scene, dense.depth, direction);
  }
  const double shift = 0.5 * (displacement[0] + displacement[1]);
  const double bias = 0.5 * (displacement[0] - displacement[1]);
  // Measured (x, y): displaced by 0.08 / -0.07 pixel, bias worth -0.13 /
  // -0.30 pixel of slant (<= 0.04 % of the inverse depth). Sampling the frames
  // bilinearly without oversampling: -0.28 pixel along y, and the mirrored
  // y-plane's best integer shift (0, -1).
  EXPECT_LT(std::abs(shift), 0.2) << "depth map displaced by " << shift << " px";
  EXPECT_LT(std::abs(bias), 0.45) << "inverse-depth bias worth " << bias << " px";
  RecordProperty("displacement_px", std::to_string(shift));
  RecordProperty("bias_px", std::to_string(bias));
}

INSTANTIATE_TEST_SUITE_P(Slant, DenseDepthPlaneTest, ::testing::Values(0, 1));

// The coarse level stays near 480 columns: a level much coarser than that
// for the image blurs the seed and the confidence across depth edges (720p
// at 1/4 did, docs/experiments/230-coarse-level-width.md), a much finer one
// costs the sweep the cube of the scale.
TEST(DenseDepth, TheCoarseLevelKeepsAboutFourHundredAndEightyColumns) {
  const DenseOptions defaults;
  for (const auto& [width, scale] : std::vector<std::pair<int, int>>{{320, 2},
                                                                     {512, 2},
                                                                     {640, 2},
                                                                     {960, 2},
                                                                     {1199, 2},
                                                                     {1280, 3},
                                                                     {1440, 3},
                                                                     {1679, 3},
                                                                     {1920, 4},
                                                                     {3840, 4}})
    EXPECT_EQ(CoarseScale(width, defaults), scale) << width << " px wide";
  DenseOptions fixed;
  fixed.coarse_scale = 1;
  EXPECT_EQ(CoarseScale(1920, fixed), 1);
}

// Below 800 px wide the coarse level has fewer than 400 columns and seeds
// the window less precisely: the window reaches one plane further each way.
TEST(DenseDepth, TheWindowReachesFurtherAboveANarrowCoarseLevel) {
  const DenseOptions defaults;
  for (const auto& [width, radius] : std::vector<std::pair<int, int>>{
           {320, 4}, {512, 4}, {640, 4}, {799, 4}, {960, 3}, {1280, 3}, {1920, 3}})
    EXPECT_EQ(RefineRadius(width, defaults), radius) << width << " px wide";
  DenseOptions fixed;
  fixed.refine_radius = 2;
  EXPECT_EQ(RefineRadius(640, fixed), 2);
  // The rule reads the coarse level, whichever scale made it: 1280 px at 1/4
  // is 320 columns.
  DenseOptions quarter;
  quarter.coarse_scale = 4;
  EXPECT_EQ(RefineRadius(1280, quarter), 4);
}

// The frames' settings: the coarse level's high-pass 1/80 of the longer side,
// the full-resolution window's fine_high_pass_ratio of it; one sigma where
// every plane is swept at full resolution, none where the high-pass is off.
TEST(DenseDepth, FramesSettingsFollowTheOptions) {
  const DenseOptions defaults;
  const DenseFramesSettings vga = DenseFramesSettingsFor(defaults, 640, 480);
  EXPECT_DOUBLE_EQ(vga.coarse_high_pass_sigma, 8.0);
  EXPECT_DOUBLE_EQ(vga.fine_high_pass_sigma, 8.0 * defaults.fine_high_pass_ratio);
  EXPECT_EQ(vga.coarse_scale, CoarseScale(640, defaults));
  EXPECT_DOUBLE_EQ(vga.prefilter_sigma, defaults.prefilter_sigma);
  EXPECT_TRUE(vga.SeparateCoarseFrames());
  DenseOptions full;
  full.coarse_scale = 1;
  const DenseFramesSettings one = DenseFramesSettingsFor(full, 640, 480);
  EXPECT_DOUBLE_EQ(one.fine_high_pass_sigma, one.coarse_high_pass_sigma);
  EXPECT_FALSE(one.SeparateCoarseFrames());
  DenseOptions off;
  off.high_pass_sigma_px = -1.0;
  const DenseFramesSettings none = DenseFramesSettingsFor(off, 640, 480);
  EXPECT_EQ(none.coarse_high_pass_sigma, 0.0);
  EXPECT_EQ(none.fine_high_pass_sigma, 0.0);
  EXPECT_FALSE(none.SeparateCoarseFrames());
}

// The pipeline has the frames made beside the sparse stage: handed in, they
// give the bits the stage gives making them itself.
TEST(DenseDepth, FramesPreparedBeforeGiveTheSameDepth) {
  const PlaneScene scene = RenderPlaneScene(Eigen::Vector3d(-0.5, 0.0, 0.6), 4);
  const DenseOptions options;
  const DenseDepth inside =
      ComputeDenseDepth(scene.burst, scene.camera, scene.poses, scene.sparse_inverse_depths);
  DenseFrames frames = PrepareDenseFrames(
      scene.burst, DenseFramesSettingsFor(options, scene.burst.width(), scene.burst.height()));
  ASSERT_FALSE(frames.coarse_others.empty());  // the coarse level's own frames travel too
  const DenseDepth handed =
      ComputeDenseDepth(scene.burst, scene.camera, scene.poses, scene.sparse_inverse_depths,
                        options, std::move(frames));
  ASSERT_GT(inside.valid_fraction, 0.5);
  for (const auto& [name, a, b] :
       {std::tuple{"depth", inside.depth, handed.depth},
        std::tuple{"confidence", inside.confidence, handed.confidence},
        std::tuple{"depth_filled", inside.depth_filled, handed.depth_filled}}) {
    ASSERT_EQ(a.size(), b.size()) << name;
    EXPECT_EQ(cv::countNonZero(a != b), 0) << name;
  }
}

// Tracks that miss the nearest part of the scene leave it outside the swept
// range, where its pixels take the nearest plane. The coarse sweep sees them
// there, the range is extended toward the camera by its width and swept
// again: the depth is right. The far end is not extended (a wrong geometry
// spreads there too); the depth check warns of it.
TEST(DenseDepth, ASurfaceNearerThanTheTracksIsSweptByExtendingTheRange) {
  const PlaneScene scene = RenderPlaneScene(Eigen::Vector3d(-0.5, 0.0, 0.6), 4);
  const cv::Mat all(scene.depth.size(), CV_8UC1, cv::Scalar(255));
  const auto score = [&](const DenseDepth& dense) {
    return EvaluateDepth(dense.depth, scene.depth, all, 1.0).abs_rel;  // the poses' own scale
  };
  // The plane's inverse depths run 0.375-0.825 across the image; the tracks'
  // are scaled so that its nearer part lies beyond their range.
  std::vector<double> tracks = scene.sparse_inverse_depths;
  for (double& w : tracks) w *= 0.7;
  DenseOptions held;
  held.range_extension_share = 0.0;
  const DenseDepth clamped =
      ComputeDenseDepth(scene.burst, scene.camera, scene.poses, tracks, held);
  const DenseDepth extended = ComputeDenseDepth(scene.burst, scene.camera, scene.poses, tracks);
  EXPECT_FALSE(clamped.range_extended);
  EXPECT_TRUE(extended.range_extended);
  EXPECT_GT(extended.max_inverse_depth, 0.825);
  EXPECT_GT(score(clamped), 0.05);   // 8.1 %
  EXPECT_LT(score(extended), 0.01);  // 0.8 %
  // Farther than the tracks, and tracks that span the scene: as it was.
  for (double& w : tracks) w *= 1.5 / 0.7;
  EXPECT_FALSE(ComputeDenseDepth(scene.burst, scene.camera, scene.poses, tracks).range_extended);
  EXPECT_FALSE(
      ComputeDenseDepth(scene.burst, scene.camera, scene.poses, scene.sparse_inverse_depths)
          .range_extended);
}

class DenseDepthInputTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    scene_ = new PlaneScene(RenderPlaneScene(Eigen::Vector3d(-0.5, 0.0, 0.6), 3));
  }
  static void TearDownTestSuite() { delete scene_; }

  static void ExpectRejected(const Burst& burst, const CameraModel& camera,
                             const std::vector<Pose>& poses, const std::vector<double>& sparse,
                             const std::string& names, const DenseOptions& options = {}) {
    try {
      ComputeDenseDepth(burst, camera, poses, sparse, options);
      ADD_FAILURE() << "accepted; expected an error naming '" << names << "'";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(names), std::string::npos) << e.what();
    }
  }
  static PlaneScene* scene_;
};
PlaneScene* DenseDepthInputTest::scene_ = nullptr;

TEST_F(DenseDepthInputTest, RejectsInconsistentInputsWithANamedReason) {
  const PlaneScene& s = *scene_;
  std::vector<Pose> two_poses(s.poses.begin(), s.poses.begin() + 2);
  ExpectRejected(s.burst, s.camera, two_poses, s.sparse_inverse_depths, "2 poses for 3 frames");
  CameraModel small = s.camera;
  small.width = 320;
  ExpectRejected(s.burst, small, s.poses, s.sparse_inverse_depths, "camera is 320x480");
  ExpectRejected(s.burst, s.camera, s.poses, {}, "no sparse inverse depths");
  ExpectRejected(s.burst, s.camera, s.poses, {0.5, -1.0}, "sparse inverse depth 1");
  std::vector<Pose> bad_pose = s.poses;
  bad_pose[2].T.x() = std::nan("");
  ExpectRejected(s.burst, s.camera, bad_pose, s.sparse_inverse_depths, "pose 2 is not finite");
  Burst one_frame = s.burst;
  one_frame.gray.resize(1);
  ExpectRejected(one_frame, s.camera, {s.poses[0]}, s.sparse_inverse_depths, "at least one other");
  Burst color = s.burst;
  cv::cvtColor(color.gray[1], color.gray[1], cv::COLOR_GRAY2BGR);
  ExpectRejected(color, s.camera, s.poses, s.sparse_inverse_depths, "frame 1");
  Burst small_color = s.burst;
  cv::cvtColor(s.burst.gray[0](cv::Rect(0, 0, 320, 240)), small_color.reference_color,
               cv::COLOR_GRAY2BGR);
  ExpectRejected(small_color, s.camera, s.poses, s.sparse_inverse_depths, "reference_color");
  DenseOptions options;
  options.planes = 1;
  ExpectRejected(s.burst, s.camera, s.poses, s.sparse_inverse_depths, "planes", options);
  options = {};
  options.discontinuity_parallax = -0.6;
  ExpectRejected(s.burst, s.camera, s.poses, s.sparse_inverse_depths, "discontinuity_parallax",
                 options);
  options = {};
  options.raw_discontinuity_radius = -1;
  ExpectRejected(s.burst, s.camera, s.poses, s.sparse_inverse_depths, "raw_discontinuity_radius",
                 options);
  options = {};
  options.coarse_shiftable_radius = -1;
  ExpectRejected(s.burst, s.camera, s.poses, s.sparse_inverse_depths, "coarse_shiftable_radius",
                 options);
  options = {};
  options.weak_texture_gradient = -1.0;
  ExpectRejected(s.burst, s.camera, s.poses, s.sparse_inverse_depths, "weak_texture_gradient",
                 options);
  options = {};
  // Frames made with the defaults' settings, given to options that differ.
  const DenseFramesSettings defaults =
      DenseFramesSettingsFor(DenseOptions(), s.burst.width(), s.burst.height());
  for (const std::string changed : {"prefilter_sigma", "fine_high_pass_ratio"}) {
    options = {};
    if (changed == "prefilter_sigma") options.prefilter_sigma = 0.8;
    if (changed == "fine_high_pass_ratio") options.fine_high_pass_ratio = 1.0;
    try {
      ComputeDenseDepth(s.burst, s.camera, s.poses, s.sparse_inverse_depths, options,
                        PrepareDenseFrames(s.burst, defaults));
      ADD_FAILURE() << "accepted frames made with another " << changed;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("prepared frames"), std::string::npos) << e.what();
    }
  }
  // Frames whose coarse level's own frames are missing.
  options = {};
  DenseFrames without_coarse = PrepareDenseFrames(s.burst, defaults);
  ASSERT_FALSE(without_coarse.coarse_others.empty());
  without_coarse.coarse_others.clear();
  without_coarse.coarse_reference.release();
  try {
    ComputeDenseDepth(s.burst, s.camera, s.poses, s.sparse_inverse_depths, options,
                      std::move(without_coarse));
    ADD_FAILURE() << "accepted frames without the coarse level's";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("prepared frames"), std::string::npos) << e.what();
  }
  options = {};
  options.fine_high_pass_ratio = 0.0;
  ExpectRejected(s.burst, s.camera, s.poses, s.sparse_inverse_depths, "fine_high_pass_ratio",
                 options);
  options = {};
  options.oversample_max_pixels = -1;
  ExpectRejected(s.burst, s.camera, s.poses, s.sparse_inverse_depths, "oversample_max_pixels",
                 options);
}

}  // namespace
}  // namespace dfsm
