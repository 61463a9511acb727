#include "core/synth/burst_synthesizer.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <stdexcept>
#include <string>

#include "core/camera/rolling_shutter.h"
#include "core/io/file_util.h"
#include "core/io/image_decode.h"
#include "core/io/jpeg_encode.h"
#include "core/io/png_encode.h"
#include "core/synth/camera_path.h"
#include "core/synth/moving_object.h"
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
  Require(o.reference >= 0 && o.reference < o.frames,
          "reference must be the index of one of the frames (0 to frames - 1)");
  Require(o.f >= 0.0 && std::isfinite(o.f), "f must be positive (or 0 for the default)");
  Require(std::isfinite(o.k1) && std::isfinite(o.k2), "k1 and k2 must be finite");
  Require(o.baseline >= 0.0 && o.baseline <= 1.0, "baseline must be between 0 and 1 m");
  Require(o.rotation_deg >= 0.0 && o.rotation_deg <= 20.0,
          "rotation_deg must be between 0 and 20 degrees");
  Require(o.oscillation_deg >= 0.0 && o.oscillation_deg <= 2.0,
          "oscillation_deg must be between 0 and 2 degrees");
  Require(o.noise_sigma >= 0.0 && o.noise_sigma <= 50.0,
          "noise_sigma must be between 0 and 50 grey levels");
  Require(o.jpeg_quality >= 0 && o.jpeg_quality <= 100, "jpeg_quality must be between 0 and 100");
  Require(o.supersampling >= 1 && o.supersampling <= 8, "supersampling must be between 1 and 8");
  Require(o.moving_object >= 0.0 && o.moving_object <= 0.2,
          "moving_object must be between 0 and 0.2 image widths per frame");
  Require(o.curved_surfaces >= 0 && o.curved_surfaces <= 8,
          "curved_surfaces must be between 0 and 8");
  Require(o.untextured >= 0.0 && o.untextured <= 1.0, "untextured must be between 0 and 1");
  Require(o.color || !o.effects.bayer,
          "bayer (a colour filter array) needs colour frames: a grey burst is a monochrome sensor");
  o.effects.Check();
}

// The D->U map must be monotonic out to the image corner, or the captured
// image would fold over itself (the extra radial term k3 included).
void RequireInvertibleDistortion(const SynthOptions& options) {
  Require(RenderedLensIsInvertible(options),
          options.effects.k3 != 0.0 ? "k1/k2/k3 fold the image over itself before its corner"
                                    : "k1/k2 fold the image over itself before its corner");
}

// The nearest surface along a ray at time t (frame intervals), the moving
// object included; *object tells whether it was the object.
bool TraceAt(const TexturedScene& scene, const MovingObject* moving, const Eigen::Vector3d& centre,
             const Eigen::Vector3d& direction, double t, double* distance, cv::Vec3f* bgr,
             bool* object) {
  bool hit = scene.Trace(centre, direction, distance, bgr);
  *object = false;
  if (moving != nullptr) {
    const double lambda = moving->Intersect(centre, direction, t);
    if (lambda > 0.0 && (!hit || lambda < *distance)) {
      *distance = lambda;
      *bgr = moving->Sample(centre + lambda * direction, t);
      *object = hit = true;
    }
  }
  return hit;
}

struct RenderInputs {
  const TexturedScene& scene;
  const MovingObject* moving;  // may be null
  const CameraModel& camera;
  const CameraEffects& effects;
  const HandheldPath& path;
  int supersampling;
};

// Renders frame `frame` of the path: the mean of supersampling^2 rays per
// pixel, spread over the pixel's footprint (anti-aliasing). With a rolling
// shutter each row is seen from the pose at its own exposure time. With motion
// blur the shutter stays open exposure_time of the frame interval around that
// time: kMotionBlurSamples sub-frame poses, each with a grid of at most
// supersampling^2 / kMotionBlurSamples rays (at least one) whose sub-pixel
// offset differs from sub-frame to sub-frame, so that the ray count stays
// bounded and the pixel footprint is still covered. *object_mask (when given)
// marks the pixels where any ray saw the moving object.
cv::Mat RenderFrame(const RenderInputs& in, int frame, cv::Mat* object_mask) {
  const CameraModel& camera = in.camera;
  const double readout = in.effects.rolling_shutter_readout;
  const double exposure = in.effects.exposure_time;
  const int times = exposure > 0.0 ? CameraEffects::kMotionBlurSamples : 1;
  static_assert(CameraEffects::kMotionBlurSamples == 8, "the offsets below permute 8 strata");
  int grid = in.supersampling;
  if (times > 1) {
    grid = 1;
    while ((grid + 1) * (grid + 1) * times <= in.supersampling * in.supersampling) ++grid;
  }
  // Sub-pixel offset of each sub-frame's grid, as permuted strata of the cell
  // (uncorrelated with time); the cell's centre without blur.
  std::vector<double> jitter_x(times, 0.5), jitter_y(times, 0.5);
  if (times > 1)
    for (int k = 0; k < times; ++k) {
      jitter_x[k] = ((3 * k) % times + 0.5) / times;
      jitter_y[k] = ((5 * k + 2) % times + 0.5) / times;
    }
  cv::Mat image(camera.height, camera.width, CV_32FC3);
  if (object_mask != nullptr) *object_mask = cv::Mat(camera.height, camera.width, CV_8UC1, 0.0);
  cv::parallel_for_(cv::Range(0, camera.height), [&](const cv::Range& rows) {
    std::vector<Eigen::Matrix3d> to_reference(times);
    std::vector<Eigen::Vector3d> centres(times);
    std::vector<double> sample_time(times);
    for (int v = rows.start; v < rows.end; ++v) {
      const double row_time = frame + RowTime(readout, v, camera.height);
      for (int k = 0; k < times; ++k) {
        sample_time[k] = times > 1 ? row_time + exposure * ((k + 0.5) / times - 0.5) : row_time;
        const Pose pose = in.path.At(sample_time[k]);
        to_reference[k] = pose.R.transpose();
        centres[k] = pose.Centre();
      }
      cv::Vec3f* out = image.ptr<cv::Vec3f>(v);
      uchar* mask = object_mask != nullptr ? object_mask->ptr<uchar>(v) : nullptr;
      for (int u = 0; u < camera.width; ++u) {
        cv::Vec3f sum(0.0f, 0.0f, 0.0f);
        int hits = 0;
        bool saw_object = false;
        for (int k = 0; k < times; ++k) {
          for (int sy = 0; sy < grid; ++sy) {
            for (int sx = 0; sx < grid; ++sx) {
              const Eigen::Vector2d pixel(u + (sx + jitter_x[k]) / grid - 0.5,
                                          v + (sy + jitter_y[k]) / grid - 0.5);
              const Eigen::Vector2d x = RenderedPixelToUndistorted(camera, in.effects, pixel);
              double distance;
              cv::Vec3f bgr;
              bool object;
              if (TraceAt(in.scene, in.moving, centres[k],
                          to_reference[k] * Eigen::Vector3d(x.x(), x.y(), 1.0), sample_time[k],
                          &distance, &bgr, &object)) {
                sum += bgr;
                ++hits;
                saw_object = saw_object || object;
              }
            }
          }
        }
        out[u] = hits > 0 ? sum * (1.0f / hits) : cv::Vec3f(0.0f, 0.0f, 0.0f);
        if (mask != nullptr && saw_object) mask[u] = 255;
      }
    }
  });
  return image;
}

// Depth of the surface the reference frame shows at each pixel centre,
// through the rendering's lens: Z in the camera of the pixel's row. With a
// rolling shutter each row of the reference is seen from the pose at its own
// time, as RenderFrame renders it (and as the pipeline's depth is defined,
// core/dense/sweep_level.h: reference row y from its own row's pose); from
// the frame's middle-row pose alone, rows far from the middle would be
// compared with a view shifted by the motion during the readout (several
// pixels at 2 deg of tremor). The moving object is where it is at the row's
// time.
cv::Mat RenderReferenceDepth(const TexturedScene& scene, const MovingObject* moving,
                             const CameraModel& camera, const CameraEffects& effects,
                             const HandheldPath& path, int reference) {
  const double readout = effects.rolling_shutter_readout;
  cv::Mat depth(camera.height, camera.width, CV_32FC1, cv::Scalar(0.0f));
  cv::parallel_for_(cv::Range(0, camera.height), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      const double row_time = reference + RowTime(readout, v, camera.height);
      const Pose pose = path.At(row_time);
      const Eigen::Matrix3d to_reference = pose.R.transpose();
      const Eigen::Vector3d centre = pose.Centre();
      float* out = depth.ptr<float>(v);
      for (int u = 0; u < camera.width; ++u) {
        const Eigen::Vector2d x =
            RenderedPixelToUndistorted(camera, effects, Eigen::Vector2d(u, v));
        double distance;
        cv::Vec3f bgr;
        bool object;
        // The ray (x, y, 1) has unit z in the row's camera, so the distance
        // along it is the depth.
        if (TraceAt(scene, moving, centre, to_reference * Eigen::Vector3d(x.x(), x.y(), 1.0),
                    row_time, &distance, &bgr, &object))
          out[u] = static_cast<float>(distance);
      }
    }
  });
  return depth;
}

// Shot noise, sensor (read) noise, 8-bit quantization and the optional JPEG
// round trip; with a colour filter array the noise falls on the photosites and
// the quantized mosaic is demosaiced.
cv::Mat Capture(const cv::Mat& radiance, const SynthOptions& options, int frame_index) {
  const bool bayer = options.color && options.effects.bayer;
  cv::Mat image = radiance;
  if (!options.color) cv::cvtColor(radiance, image, cv::COLOR_BGR2GRAY);
  if (bayer) image = BayerMosaic(radiance);
  if (options.effects.shot_noise_gain > 0.0) {
    if (image.data == radiance.data) image = radiance.clone();
    AddShotNoise(options.effects.shot_noise_gain, frame_index, options.seed, &image);
  }
  if (options.noise_sigma > 0.0) {
    cv::Mat noise(image.size(), image.type());
    cv::RNG rng(options.seed * 1000003ULL + static_cast<uint64_t>(frame_index) + 1);
    rng.fill(noise, cv::RNG::NORMAL, cv::Scalar::all(0.0), cv::Scalar::all(options.noise_sigma));
    image = image + noise;
  }
  cv::Mat captured;
  image.convertTo(captured, CV_MAKETYPE(CV_8U, image.channels()));  // rounds and saturates
  if (bayer) captured = Demosaic(captured);
  if (options.jpeg_quality > 0) {
    const std::vector<unsigned char> jpeg = EncodeJpeg(captured, options.jpeg_quality);
    captured =
        DecodeImage(std::string_view(reinterpret_cast<const char*>(jpeg.data()), jpeg.size()));
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
          {"oscillation_deg", o.oscillation_deg},
          {"hand_path", o.hand_path},
          {"noise_sigma", o.noise_sigma},
          {"jpeg_quality", o.jpeg_quality},
          {"supersampling", o.supersampling},
          {"seed", o.seed},
          {"reference", o.reference},
          {"effects", ToJson(o.effects)},
          {"moving_object", o.moving_object},
          {"curved_surfaces", o.curved_surfaces},
          {"untextured", o.untextured},
          {"textures", textures}};
}

}  // namespace

SceneOptions SceneOptionsFor(const SynthOptions& options, double f) {
  SceneOptions scene_options;
  scene_options.width = options.width;
  scene_options.height = options.height;
  scene_options.f = f;
  scene_options.seed = options.seed;
  scene_options.texture_dir = options.texture_dir;
  scene_options.untextured = options.untextured;
  scene_options.curved_surfaces = options.curved_surfaces;
  return scene_options;
}

CameraModel SynthCamera(const SynthOptions& options) {
  CameraModel camera;
  camera.width = options.width;
  camera.height = options.height;
  camera.f = options.f > 0.0 ? options.f : 1.1 * std::max(options.width, options.height);
  camera.cx = 0.5 * options.width;
  camera.cy = 0.5 * options.height;
  camera.k1 = options.k1;
  camera.k2 = options.k2;
  return camera;
}

bool RenderedLensIsInvertible(const SynthOptions& options) {
  const CameraModel camera = SynthCamera(options);
  const double k3 = options.effects.k3;
  const double r_corner = camera.CornerRadiusPx() / camera.f;
  // d r_u / d r_d at 101 radii out to the corner, with a margin: a lens that
  // nearly folds squeezes its corner into a few pixels.
  for (int step = 0; step <= 100; ++step) {
    const double r2 = std::pow(r_corner * step / 100.0, 2);
    if (!(1.0 + 3.0 * camera.k1 * r2 + 5.0 * camera.k2 * r2 * r2 + 7.0 * k3 * r2 * r2 * r2 > 0.05))
      return false;
  }
  return true;
}

SynthBurst SynthesizeBurst(const SynthOptions& options) {
  Validate(options);
  RequireInvertibleDistortion(options);
  const CameraModel camera = SynthCamera(options);

  const SceneOptions scene_options = SceneOptionsFor(options, camera.f);
  const TexturedScene scene(scene_options);
  std::optional<MovingObject> moving;
  if (options.moving_object > 0.0) {
    MovingObjectOptions object_options;
    object_options.speed = options.moving_object;
    object_options.width = options.width;
    object_options.height = options.height;
    object_options.f = camera.f;
    object_options.depth = 0.75 * scene_options.near_depth;
    object_options.frames = options.frames;
    object_options.seed = options.seed;
    moving.emplace(object_options, cv::Mat());
  }
  const MovingObject* moving_object = moving ? &*moving : nullptr;

  CameraPathOptions path_options;
  path_options.frames = options.frames;
  path_options.baseline = options.baseline;
  path_options.rotation_deg = options.rotation_deg;
  path_options.oscillation_deg = options.oscillation_deg;
  if (options.hand_path) path_options.between_frames = CameraPathOptions::BetweenFrames::kHand;
  path_options.seed = options.seed;

  // The path is in the coordinates of its first frame, where the scene is
  // laid out; frames and depth are rendered from it whichever frame is the
  // reference, and only the truth's poses are re-expressed.
  const HandheldPath path(path_options);
  SynthBurst burst;
  burst.effects = options.effects;
  burst.truth.camera = camera;
  burst.truth.poses = PosesRelativeTo(path.FramePoses(), options.reference);
  burst.manifest.width = options.width;
  burst.manifest.height = options.height;
  burst.manifest.pixel_format = options.color ? "bgr8" : "gray8";
  burst.manifest.reference = options.reference;
  burst.truth.depth = RenderReferenceDepth(scene, moving_object, camera, options.effects, path,
                                           burst.manifest.reference);
  burst.manifest.source = {{"device", "synthetic"},
                           {"fps", 30.0},
                           {"synthetic", OptionsJson(options, camera, scene.texture_names())}};
  const RenderInputs inputs{scene,           moving_object, camera,
                            options.effects, path,          options.supersampling};
  for (int i = 0; i < options.frames; ++i) {
    cv::Mat mask;
    cv::Mat radiance = RenderFrame(inputs, i, moving_object != nullptr ? &mask : nullptr);
    if (options.effects.photometric())
      ApplyPhotometricEffects(options.effects, i, options.seed, &radiance);
    burst.frames.push_back(Capture(radiance, options, i));
    if (moving_object != nullptr) {
      burst.object_boxes.push_back(cv::boundingRect(mask));
      burst.object_masks.push_back(mask);
    }
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
  // What the camera model leaves out, beside it: the rendering's extra lens
  // terms and where the moving object is.
  nlohmann::json truth = nlohmann::json::parse(ReadFileToString(burst_dir / "ground_truth.json"));
  truth["k3"] = burst.effects.k3;
  truth["p1"] = burst.effects.p1;
  truth["p2"] = burst.effects.p2;
  truth["rendered_distortion"] =
      "D->U of the captured normalized (x, y), r^2 = x^2 + y^2: x_u = x (1 + k1 r^2 + k2 r^4 + k3 "
      "r^6) + 2 p1 x y + p2 (r^2 + 2 x^2), y_u = y (1 + k1 r^2 + k2 r^4 + k3 r^6) + p1 (r^2 + 2 "
      "y^2) + 2 p2 x y";
  if (!burst.object_masks.empty()) {
    std::filesystem::create_directories(burst_dir / "object_masks");
    nlohmann::json frames = nlohmann::json::array();
    for (size_t i = 0; i < burst.object_masks.size(); ++i) {
      char name[40];
      std::snprintf(name, sizeof(name), "object_masks/%06zu.png", i);
      WriteFileAtomically(burst_dir / name,
                          EncodePng(burst.object_masks[i], PngCompression::kCompact));
      const cv::Rect& box = burst.object_boxes[i];
      frames.push_back({{"mask", name}, {"box", {box.x, box.y, box.width, box.height}}});
    }
    truth["moving_object"] = {
        {"frames", frames},
        {"note",
         "pixels where any sample saw the object (255 in the mask; box x, y, width, height); "
         "depth_gt shows it where each reference row saw it (the row's time)"}};
  }
  WriteFileAtomically(burst_dir / "ground_truth.json", truth.dump(2) + "\n");
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
