#include "core/synth/burst_synthesizer.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

#include "core/synth/camera_path.h"
#include "core/synth/textured_scene.h"

namespace dfsm {
namespace {

constexpr int64_t kFramePeriodNs = 33'333'333;  // 30 fps

void Require(bool condition, const std::string& message) {
  if (!condition) throw std::invalid_argument(message);
}

void Validate(const SynthOptions& o) {
  Require(o.width >= 64 && o.width <= 8192, "width must be between 64 and 8192 pixels");
  Require(o.height >= 64 && o.height <= 8192, "height must be between 64 and 8192 pixels");
  Require(o.frames >= 3 && o.frames <= 200, "frames must be between 3 and 200");
  Require(o.f >= 0.0 && std::isfinite(o.f), "f must be positive (or 0 for the default)");
  Require(std::isfinite(o.k1) && std::isfinite(o.k2), "k1 and k2 must be finite");
  Require(o.baseline >= 0.0 && o.baseline <= 1.0, "baseline must be between 0 and 1 m");
  Require(o.rotation_deg >= 0.0 && o.rotation_deg <= 20.0,
          "rotation_deg must be between 0 and 20 degrees");
  Require(o.noise_sigma >= 0.0 && o.noise_sigma <= 50.0,
          "noise_sigma must be between 0 and 50 grey levels");
  Require(o.jpeg_quality >= 0 && o.jpeg_quality <= 100, "jpeg_quality must be between 0 and 100");
  Require(o.supersampling >= 1 && o.supersampling <= 8, "supersampling must be between 1 and 8");
  o.effects.Check();
}

// The D->U map must be monotonic out to the image corner, or the captured
// image would fold over itself.
void RequireInvertibleDistortion(const CameraModel& camera) {
  const double r_corner = std::hypot(std::max(camera.cx, camera.width - camera.cx),
                                     std::max(camera.cy, camera.height - camera.cy)) /
                          camera.f;
  for (int step = 0; step <= 100; ++step) {
    const double r2 = std::pow(r_corner * step / 100.0, 2);
    Require(1.0 + 3.0 * camera.k1 * r2 + 5.0 * camera.k2 * r2 * r2 > 0.05,
            "k1/k2 fold the image over itself before its corner");
  }
}

// Renders frame `frame` of the path: the mean of supersampling^2 rays per
// pixel, spread over the pixel's footprint (anti-aliasing). With a rolling
// shutter each row is seen from the pose at its own exposure time.
cv::Mat RenderFrame(const TexturedScene& scene, const CameraModel& camera,
                    const std::vector<Pose>& path, int frame, double readout, int supersampling) {
  cv::Mat image(camera.height, camera.width, CV_32FC3);
  cv::parallel_for_(cv::Range(0, camera.height), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      const Pose pose = readout > 0.0
                            ? PoseAtTime(path, frame + readout * ((v + 0.5) / camera.height - 0.5))
                            : path[frame];
      const Eigen::Matrix3d to_reference = pose.R.transpose();
      const Eigen::Vector3d centre = pose.Centre();
      cv::Vec3f* out = image.ptr<cv::Vec3f>(v);
      for (int u = 0; u < camera.width; ++u) {
        cv::Vec3f sum(0.0f, 0.0f, 0.0f);
        int hits = 0;
        for (int sy = 0; sy < supersampling; ++sy) {
          for (int sx = 0; sx < supersampling; ++sx) {
            const Eigen::Vector2d pixel(u + (sx + 0.5) / supersampling - 0.5,
                                        v + (sy + 0.5) / supersampling - 0.5);
            const Eigen::Vector2d x = camera.PixelToUndistorted(pixel);
            double distance;
            cv::Vec3f bgr;
            if (scene.Trace(centre, to_reference * Eigen::Vector3d(x.x(), x.y(), 1.0), &distance,
                            &bgr)) {
              sum += bgr;
              ++hits;
            }
          }
        }
        out[u] = hits > 0 ? sum * (1.0f / hits) : cv::Vec3f(0.0f, 0.0f, 0.0f);
      }
    }
  });
  return image;
}

// Depth (Z in the reference camera) of the surface seen at each pixel centre.
cv::Mat RenderReferenceDepth(const TexturedScene& scene, const CameraModel& camera) {
  cv::Mat depth(camera.height, camera.width, CV_32FC1, cv::Scalar(0.0f));
  cv::parallel_for_(cv::Range(0, camera.height), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      float* out = depth.ptr<float>(v);
      for (int u = 0; u < camera.width; ++u) {
        const Eigen::Vector2d x = camera.PixelToUndistorted(Eigen::Vector2d(u, v));
        double distance;
        cv::Vec3f bgr;
        // The ray (x, y, 1) has unit z, so the distance along it is the depth.
        if (scene.Trace(Eigen::Vector3d::Zero(), Eigen::Vector3d(x.x(), x.y(), 1.0), &distance,
                        &bgr))
          out[u] = static_cast<float>(distance);
      }
    }
  });
  return depth;
}

// Sensor noise, 8-bit quantization and the optional JPEG round trip.
cv::Mat Capture(const cv::Mat& radiance, const SynthOptions& options, int frame_index) {
  cv::Mat image = radiance;
  if (!options.color) cv::cvtColor(radiance, image, cv::COLOR_BGR2GRAY);
  if (options.noise_sigma > 0.0) {
    cv::Mat noise(image.size(), image.type());
    cv::RNG rng(options.seed * 1000003ULL + static_cast<uint64_t>(frame_index) + 1);
    rng.fill(noise, cv::RNG::NORMAL, cv::Scalar::all(0.0), cv::Scalar::all(options.noise_sigma));
    image = image + noise;
  }
  cv::Mat captured;
  image.convertTo(captured, options.color ? CV_8UC3 : CV_8UC1);  // rounds and saturates
  if (options.jpeg_quality > 0) {
    std::vector<unsigned char> jpeg;
    cv::imencode(".jpg", captured, jpeg, {cv::IMWRITE_JPEG_QUALITY, options.jpeg_quality});
    captured = cv::imdecode(jpeg, options.color ? cv::IMREAD_COLOR : cv::IMREAD_GRAYSCALE);
  }
  return captured;
}

nlohmann::json OptionsJson(const SynthOptions& o, const CameraModel& camera,
                           const std::vector<std::string>& textures) {
  return {{"generator", "dfsm synth"},
          {"f", camera.f},
          {"k1", o.k1},
          {"k2", o.k2},
          {"baseline_m", o.baseline},
          {"rotation_deg", o.rotation_deg},
          {"noise_sigma", o.noise_sigma},
          {"jpeg_quality", o.jpeg_quality},
          {"supersampling", o.supersampling},
          {"seed", o.seed},
          {"effects", ToJson(o.effects)},
          {"textures", textures}};
}

}  // namespace

SynthBurst SynthesizeBurst(const SynthOptions& options) {
  Validate(options);
  CameraModel camera;
  camera.width = options.width;
  camera.height = options.height;
  camera.f = options.f > 0.0 ? options.f : 1.1 * std::max(options.width, options.height);
  camera.cx = 0.5 * options.width;
  camera.cy = 0.5 * options.height;
  camera.k1 = options.k1;
  camera.k2 = options.k2;
  RequireInvertibleDistortion(camera);

  SceneOptions scene_options;
  scene_options.width = options.width;
  scene_options.height = options.height;
  scene_options.f = camera.f;
  scene_options.seed = options.seed;
  scene_options.texture_dir = options.texture_dir;
  const TexturedScene scene(scene_options);

  CameraPathOptions path_options;
  path_options.frames = options.frames;
  path_options.baseline = options.baseline;
  path_options.rotation_deg = options.rotation_deg;
  path_options.seed = options.seed;

  SynthBurst burst;
  burst.truth.camera = camera;
  burst.truth.poses = HandheldCameraPath(path_options);
  burst.truth.depth = RenderReferenceDepth(scene, camera);

  burst.manifest.width = options.width;
  burst.manifest.height = options.height;
  burst.manifest.pixel_format = options.color ? "bgr8" : "gray8";
  burst.manifest.reference = 0;
  burst.manifest.source = {{"device", "synthetic"},
                           {"fps", 30.0},
                           {"synthetic", OptionsJson(options, camera, scene.texture_names())}};
  for (int i = 0; i < options.frames; ++i) {
    cv::Mat radiance = RenderFrame(scene, camera, burst.truth.poses, i,
                                   options.effects.rolling_shutter_readout, options.supersampling);
    if (options.effects.any()) ApplyPhotometricEffects(options.effects, i, options.seed, &radiance);
    burst.frames.push_back(Capture(radiance, options, i));
    BurstFrameInfo info;
    char name[32];
    std::snprintf(name, sizeof(name), "frames/%06d.png", i);
    info.file = name;
    info.timestamp_ns = i * kFramePeriodNs;
    info.sequence = i;
    burst.manifest.frames.push_back(info);
  }
  return burst;
}

void WriteSynthBurst(const std::filesystem::path& burst_dir, const SynthBurst& burst) {
  // Ground truth first: the manifest, written last by WriteBurst, marks the
  // burst complete.
  std::filesystem::create_directories(burst_dir);
  WriteGroundTruth(burst_dir, burst.truth);
  WriteBurst(burst_dir, burst.manifest, burst.frames);
}

Burst ToBurst(const SynthBurst& synth) {
  Burst burst;
  burst.manifest = synth.manifest;
  for (const cv::Mat& frame : synth.frames) burst.gray.push_back(ToGray8(frame));
  burst.reference_color = synth.frames[burst.reference()].clone();
  return burst;
}

std::vector<double> SparseInverseDepthsFromTruth(const GroundTruth& truth, int grid) {
  const cv::Mat& depth = truth.depth;
  Require(depth.type() == CV_32FC1 && !depth.empty(), "the ground truth has no depth map");
  Require(grid >= 1 && grid <= std::min(depth.rows, depth.cols),
          "grid " + std::to_string(grid) + " does not fit the depth map");
  std::vector<double> inverse_depths;
  for (int row = 0; row < grid; ++row)
    for (int column = 0; column < grid; ++column) {
      const float z = depth.at<float>((2 * row + 1) * depth.rows / (2 * grid),
                                      (2 * column + 1) * depth.cols / (2 * grid));
      if (z > 0.0f) inverse_depths.push_back(1.0 / z);
    }
  return inverse_depths;
}

}  // namespace dfsm
