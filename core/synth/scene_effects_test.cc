// The scene content of issue 13 beyond textured planes: a moving object,
// curved surfaces, untextured regions; and the camera effects that need the
// ground truth to check them (motion blur, lens terms beyond the model).
#include <gtest/gtest.h>

#include <Eigen/SVD>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/io/file_util.h"
#include "core/synth/burst_synthesizer.h"
#include "core/synth/textured_scene.h"

namespace dfsm {
namespace {

SynthOptions SceneTestOptions() {
  SynthOptions options;
  options.width = 160;
  options.height = 120;
  options.frames = 3;
  options.noise_sigma = 0.0;
  options.supersampling = 3;
  options.rotation_deg = 1.0;
  return options;
}

cv::Mat Gray(const cv::Mat& frame) {
  cv::Mat gray;
  cv::cvtColor(frame, gray, cv::COLOR_BGR2GRAY);
  return gray;
}

// Mean absolute grey difference between the reference and frame i sampled
// where the ground truth (through the rendered lens) says each reference pixel
// moved, `shift` pixels added to the prediction: the geometry holds when the
// unshifted prediction matches far better than the shifted one.
double WarpErrorWithEffects(const SynthBurst& burst, int i, double shift) {
  const CameraModel& camera = burst.truth.camera;
  const Pose& pose = burst.truth.poses[i];
  const cv::Mat reference = Gray(burst.frames[0]), frame = Gray(burst.frames[i]);
  double sum = 0.0;
  int count = 0;
  for (int v = 10; v < camera.height - 10; v += 2) {
    for (int u = 10; u < camera.width - 10; u += 2) {
      const double depth = burst.truth.depth.at<float>(v, u);
      const Eigen::Vector2d x =
          RenderedPixelToUndistorted(camera, burst.effects, Eigen::Vector2d(u, v));
      const Eigen::Vector3d X = pose.Transform(depth * Eigen::Vector3d(x.x(), x.y(), 1.0));
      const auto pixel = RenderedUndistortedToPixel(camera, burst.effects, X.head<2>() / X.z());
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

double GradientEnergy(const cv::Mat& frame) {
  cv::Mat gx, gy;
  cv::Sobel(Gray(frame), gx, CV_32F, 1, 0);
  cv::Sobel(Gray(frame), gy, CV_32F, 0, 1);
  return cv::sum(gx.mul(gx) + gy.mul(gy))[0];
}

TEST(SceneEffects, MotionBlurLowersGradientEnergyAndKeepsTheGeometry) {
  SynthOptions options = SceneTestOptions();
  options.rotation_deg = 3.0;  // ~4 px of motion per frame at f = 176 px
  // On the line between frame poses, so that the first and last frames'
  // exposures are straight (below); the hand's path curves through them.
  options.hand_path = false;
  const SynthBurst sharp = SynthesizeBurst(options);
  options.effects.exposure_time = 1.0;
  const SynthBurst blurred = SynthesizeBurst(options);
  for (int i = 0; i < 3; ++i)
    EXPECT_LT(GradientEnergy(blurred.frames[i]), 0.85 * GradientEnergy(sharp.frames[i]))
        << "frame " << i;
  EXPECT_EQ(cv::norm(sharp.truth.depth, blurred.truth.depth, cv::NORM_INF), 0.0);
  // The poses are those of the middle of the exposure. Where the path is
  // straight during the exposure (the first and last frame: PoseAtTime
  // extrapolates linearly; between frames it turns) the blurred frame lies
  // centred on the sharp frame of its pose, closer to it than to that frame
  // moved by a pixel either way. Each blurred frame is nearer its own sharp
  // frame than the neighbouring ones.
  const cv::Rect inner(4, 4, options.width - 8, options.height - 8);
  const auto distance = [&](int blurred_index, int sharp_index, cv::Point shift) {
    return cv::norm(Gray(blurred.frames[blurred_index])(inner),
                    Gray(sharp.frames[sharp_index])(inner + shift), cv::NORM_L1);
  };
  for (const int i : {0, 2}) {
    const double centred = distance(i, i, cv::Point(0, 0));
    for (const cv::Point shift :
         {cv::Point(1, 0), cv::Point(-1, 0), cv::Point(0, 1), cv::Point(0, -1)})
      EXPECT_LT(centred, distance(i, i, shift)) << "frame " << i << " shift " << shift;
  }
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (j != i) {
        EXPECT_LT(distance(i, i, cv::Point(0, 0)), distance(i, j, cv::Point(0, 0)))
            << "frame " << i << " against sharp " << j;
      }
  EXPECT_EQ(blurred.manifest.source["synthetic"]["effects"]["motion_blur_samples"], 8);
}

TEST(SceneEffects, LensTermsBeyondTheModelAreRenderedAndRecorded) {
  SynthOptions options = SceneTestOptions();
  const SynthBurst plain = SynthesizeBurst(options);
  options.effects.k3 = 0.5;  // ~1.7 px at the corner of this 160x120 frame
  options.effects.p1 = 0.004;
  options.effects.p2 = -0.003;
  const SynthBurst lens = SynthesizeBurst(options);
  // The map: the model's plus the extra terms, and its inverse.
  const CameraModel& camera = lens.truth.camera;
  const Eigen::Vector2d pixel(150.0, 10.0);
  const double x = (150.0 - camera.cx) / camera.f, y = (10.0 - camera.cy) / camera.f;
  const double r2 = x * x + y * y;
  const Eigen::Vector2d expected =
      camera.PixelToUndistorted(pixel) +
      Eigen::Vector2d(x * 0.5 * r2 * r2 * r2 + 2 * 0.004 * x * y - 0.003 * (r2 + 2 * x * x),
                      y * 0.5 * r2 * r2 * r2 + 0.004 * (r2 + 2 * y * y) - 2 * 0.003 * x * y);
  EXPECT_LT((RenderedPixelToUndistorted(camera, lens.effects, pixel) - expected).norm(), 1e-15);
  const auto back = RenderedUndistortedToPixel(camera, lens.effects, expected);
  ASSERT_TRUE(back.has_value());
  EXPECT_LT((*back - pixel).norm(), 1e-6);
  // The centre barely moves, the corners do.
  const auto difference = [](const cv::Mat& a, const cv::Mat& b, cv::Rect r) {
    return cv::norm(Gray(a)(r), Gray(b)(r), cv::NORM_L1) / r.area();
  };
  const double centre = difference(plain.frames[0], lens.frames[0], cv::Rect(75, 55, 10, 10));
  const double corner = difference(plain.frames[0], lens.frames[0], cv::Rect(0, 0, 10, 10));
  EXPECT_LT(centre, 1.0);
  EXPECT_GT(corner, 3.0 * centre + 2.0);
  // The depth is that seen through the rendered lens, and the frames follow it.
  EXPECT_GT(cv::norm(plain.truth.depth, lens.truth.depth, cv::NORM_INF), 0.0);
  for (int i = 1; i < 3; ++i) {
    const double aligned = WarpErrorWithEffects(lens, i, 0.0);
    EXPECT_LT(aligned, 4.0) << "frame " << i;
    EXPECT_LT(aligned * 2.0, WarpErrorWithEffects(lens, i, 1.5)) << "frame " << i;
  }
  // The camera stays the model the pipeline estimates; the extra terms go beside it.
  EXPECT_EQ(lens.truth.camera.k1, plain.truth.camera.k1);
  const auto dir = std::filesystem::temp_directory_path() / "dfsm_synth_lens_test";
  std::filesystem::remove_all(dir);
  WriteSynthBurst(dir, lens);
  const nlohmann::json truth = nlohmann::json::parse(ReadFileToString(dir / "ground_truth.json"));
  EXPECT_EQ(truth["k3"], 0.5);
  EXPECT_EQ(truth["p1"], 0.004);
  EXPECT_EQ(truth["p2"], -0.003);
  EXPECT_EQ(truth["k1"], options.k1);
  EXPECT_FALSE(truth.contains("moving_object"));
  std::filesystem::remove_all(dir);
  // A k3 that folds the image is refused by name.
  options.k1 = -0.9;
  options.effects = CameraEffects();
  options.frames = 3;
  EXPECT_NO_THROW(SynthesizeBurst(options));
  options.effects.k3 = -1.0;
  try {
    SynthesizeBurst(options);
    ADD_FAILURE() << "a folding k3 was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("k3"), std::string::npos) << e.what();
  }
}

TEST(SceneEffects, MovingObjectChangesOnlyItsOwnPixels) {
  SynthOptions options = SceneTestOptions();
  const SynthBurst still = SynthesizeBurst(options);
  options.moving_object = 0.05;  // 8 px per frame
  const SynthBurst moving = SynthesizeBurst(options);
  ASSERT_EQ(moving.object_masks.size(), 3u);
  ASSERT_TRUE(still.object_masks.empty());
  for (int i = 0; i < 3; ++i) {
    const cv::Mat& mask = moving.object_masks[i];
    cv::Mat difference, changed;
    cv::absdiff(still.frames[i], moving.frames[i], difference);
    cv::compare(difference.reshape(1, difference.rows * difference.cols), 0, changed, cv::CMP_GT);
    cv::reduce(changed, changed, 1, cv::REDUCE_MAX);  // any channel
    changed = changed.reshape(1, difference.rows);
    cv::Mat changed_outside = changed & ~mask;
    EXPECT_EQ(cv::countNonZero(changed_outside), 0) << "frame " << i;
    EXPECT_GT(cv::countNonZero(mask), 400) << "frame " << i;  // a disc of radius ~19 px
    EXPECT_GT(cv::countNonZero(changed), cv::countNonZero(mask) / 2) << "frame " << i;
  }
  // It moves 8 px per frame across the image (plus the camera's own ~1 px).
  const auto box_centre = [&](int i) {
    const cv::Rect& box = moving.object_boxes[i];
    return cv::Point2d(box.x + 0.5 * box.width, box.y + 0.5 * box.height);
  };
  const double travelled = cv::norm(box_centre(2) - box_centre(0));
  EXPECT_GT(travelled, 10.0);
  EXPECT_LT(travelled, 22.0);
  // The reference depth shows it at the reference time, in front, inside its mask.
  cv::Mat depth_changed;
  cv::compare(still.truth.depth, moving.truth.depth, depth_changed, cv::CMP_NE);
  EXPECT_GT(cv::countNonZero(depth_changed), 400);
  EXPECT_EQ(cv::countNonZero(depth_changed & ~moving.object_masks[0]), 0);
  double nearest, farthest;
  cv::minMaxLoc(moving.truth.depth, &nearest, &farthest, nullptr, nullptr, depth_changed);
  EXPECT_GT(nearest, 0.6);
  EXPECT_LT(farthest, 0.8);  // at 0.75 x the nearest patch depth (0.9 m), tilted by <= 20 deg
  // Written beside the ground truth.
  const auto dir = std::filesystem::temp_directory_path() / "dfsm_synth_object_test";
  std::filesystem::remove_all(dir);
  WriteSynthBurst(dir, moving);
  const nlohmann::json truth = nlohmann::json::parse(ReadFileToString(dir / "ground_truth.json"));
  ASSERT_EQ(truth["moving_object"]["frames"].size(), 3u);
  const nlohmann::json& frame2 = truth["moving_object"]["frames"][2];
  EXPECT_EQ(frame2["box"][0], moving.object_boxes[2].x);
  EXPECT_EQ(frame2["box"][3], moving.object_boxes[2].height);
  const cv::Mat mask =
      cv::imread((dir / frame2["mask"].get<std::string>()).string(), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(mask.empty());
  EXPECT_EQ(cv::norm(mask, moving.object_masks[2], cv::NORM_INF), 0.0);
  EXPECT_EQ(ReadGroundTruth(dir).poses.size(), 3u);  // still readable as before
  std::filesystem::remove_all(dir);
}

TEST(SceneEffects, CurvedSurfacesHaveExactNonPlanarDepth) {
  SynthOptions options = SceneTestOptions();
  options.width = 320;
  options.height = 240;
  options.supersampling = 2;
  const SynthBurst planar = SynthesizeBurst(options);
  options.curved_surfaces = 2;  // a cylinder and a sphere
  const SynthBurst curved = SynthesizeBurst(options);
  const TexturedScene scene(SceneOptionsFor(options, curved.truth.camera.f));
  ASSERT_EQ(scene.curved_surfaces().size(), 2u);
  // Every pixel whose depth changed sees a curved surface, exactly (float depth).
  const CameraModel& camera = curved.truth.camera;
  std::vector<std::vector<Eigen::Vector3d>> points(2);
  int changed = 0;
  for (int v = 0; v < camera.height; ++v)
    for (int u = 0; u < camera.width; ++u) {
      const float depth = curved.truth.depth.at<float>(v, u);
      if (depth == planar.truth.depth.at<float>(v, u)) continue;
      ++changed;
      const Eigen::Vector2d x = camera.PixelToUndistorted(Eigen::Vector2d(u, v));
      const Eigen::Vector3d X = depth * Eigen::Vector3d(x.x(), x.y(), 1.0);
      double best = 1e9;
      int on = -1;
      for (int k = 0; k < 2; ++k) {
        const double residual = std::abs(scene.curved_surfaces()[k].Residual(X));
        if (residual < best) best = residual, on = k;
      }
      EXPECT_LT(best, 2e-6 * depth) << "pixel " << u << ", " << v;
      points[on].push_back(X);
    }
  EXPECT_GT(changed, 2000);
  // Neither surface's points lie on a plane: the RMS distance from their
  // best plane is a sizeable share of the radius.
  for (int k = 0; k < 2; ++k) {
    ASSERT_GT(points[k].size(), 300u) << "surface " << k;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const auto& p : points[k]) mean += p;
    mean /= points[k].size();
    Eigen::MatrixXd centred(points[k].size(), 3);
    for (size_t j = 0; j < points[k].size(); ++j)
      centred.row(j) = (points[k][j] - mean).transpose();
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(centred);
    const double rms = svd.singularValues()[2] / std::sqrt(static_cast<double>(points[k].size()));
    EXPECT_GT(rms, 0.08 * scene.curved_surfaces()[k].radius) << "surface " << k;
  }
  // The frames follow that depth.
  for (int i = 1; i < 3; ++i) {
    const double aligned = WarpErrorWithEffects(curved, i, 0.0);
    EXPECT_LT(aligned, 4.0) << "frame " << i;
    EXPECT_LT(aligned * 2.0, WarpErrorWithEffects(curved, i, 1.5)) << "frame " << i;
  }
}

TEST(SceneEffects, UntexturedPatchesHaveNoGradient) {
  SynthOptions options = SceneTestOptions();
  options.width = 320;
  options.height = 240;
  options.supersampling = 2;
  const SynthBurst textured = SynthesizeBurst(options);
  options.untextured = 0.5;
  const SynthBurst flat = SynthesizeBurst(options);
  EXPECT_EQ(cv::norm(textured.truth.depth, flat.truth.depth, cv::NORM_INF), 0.0);
  const TexturedScene scene(SceneOptionsFor(options, flat.truth.camera.f));
  ASSERT_EQ(scene.flat_patches().size(), 2u);  // half of the 4 patches
  const CameraModel& camera = flat.truth.camera;
  cv::Mat gx, gy, magnitude_flat, magnitude_textured;
  for (const auto& [burst, magnitude] :
       {std::pair{&flat, &magnitude_flat}, std::pair{&textured, &magnitude_textured}}) {
    cv::Sobel(Gray(burst->frames[0]), gx, CV_32F, 1, 0, 3, 0.125);
    cv::Sobel(Gray(burst->frames[0]), gy, CV_32F, 0, 1, 3, 0.125);
    cv::magnitude(gx, gy, *magnitude);
  }
  int measured = 0;
  for (const int index : scene.flat_patches()) {
    const TexturedPlane& plane = scene.planes()[index];
    // The reference pixels that see this patch, away from its outline.
    cv::Mat on(camera.height, camera.width, CV_8UC1, cv::Scalar(0));
    for (int v = 0; v < camera.height; ++v)
      for (int u = 0; u < camera.width; ++u) {
        const Eigen::Vector2d x = camera.PixelToUndistorted(Eigen::Vector2d(u, v));
        const double lambda =
            plane.Intersect(Eigen::Vector3d::Zero(), Eigen::Vector3d(x.x(), x.y(), 1.0));
        if (lambda > 0.0 && std::abs(lambda - flat.truth.depth.at<float>(v, u)) < 1e-5)
          on.at<uchar>(v, u) = 255;
      }
    cv::erode(on, on, cv::Mat(), cv::Point(-1, -1), 3);
    if (cv::countNonZero(on) < 100) continue;  // hidden behind nearer patches
    ++measured;
    EXPECT_LT(cv::mean(magnitude_flat, on)[0], 0.5) << "patch " << index;
    EXPECT_GT(cv::mean(magnitude_textured, on)[0], 3.0) << "patch " << index;
  }
  EXPECT_GE(measured, 1);
  EXPECT_EQ(flat.manifest.source["synthetic"]["textures"][scene.flat_patches()[0]], "flat");
}

TEST(SceneEffects, ChecksNameTheSceneOption) {
  const auto message = [](SynthOptions options) {
    try {
      SynthesizeBurst(options);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  SynthOptions options = SceneTestOptions();
  options.moving_object = -0.1;
  EXPECT_NE(message(options).find("moving_object"), std::string::npos);
  options = SceneTestOptions();
  options.curved_surfaces = 99;
  EXPECT_NE(message(options).find("curved_surfaces"), std::string::npos);
  options = SceneTestOptions();
  options.untextured = 1.5;
  EXPECT_NE(message(options).find("untextured"), std::string::npos);
}

}  // namespace
}  // namespace dfsm
