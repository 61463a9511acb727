// A TUM RGB-D sequence as the benchmark and the tests read it
// (../shared/data/tum_fr1_xyz: rgb.txt and depth.txt list "timestamp file"
// per line; depth PNGs are 16-bit, metres * 5000, 0 = no depth).
#pragma once

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "core/camera/camera_model.h"
#include "core/camera/pose.h"
#include "core/export/calibration_import.h"
#include "core/io/burst.h"

namespace dfsm {

// The published calibration of the Freiburg 1 sequences (fr1/xyz among them),
// fitted to ha2016-d2u: bench/data/tum_freiburg1.yaml.
std::string TumFreiburg1CalibrationFile();

// The residual of `estimated`'s translations against `truth`'s (both
// X_i = R_i X_ref + T_i, one per frame) after one best scale, a fraction of
// the true translations: 0 exact, 1 unrelated, above 1 reversed. 0 where
// the truth does not move; *scale (where given): that best scale.
double TranslationResidual(const std::vector<Pose>& estimated, const std::vector<Pose>& truth,
                           double* scale = nullptr);

// The poses of the frames `kept` (GridedFeatureStats::kept_frames: the frames
// the sparse stage's poses are of), to compare with those; empty where
// `poses` is.
std::vector<Pose> PosesOfFrames(const std::vector<Pose>& poses, const std::vector<int>& kept);

// The median over windows as the benchmark reports it and the tests bound
// it: with an even count, the mean of the two middle values (0 when empty).
double WindowMedian(std::vector<double> values);

class TumSequence {
 public:
  // The sequence's frames and depth maps are 640x480.
  static constexpr int kWidth = 640, kHeight = 480;
  // The largest `downscale` accepted: 160x120, the smallest size measured
  // (docs/experiments/233-tum-320x240.md); below it a window
  // keeps too few of its tracks for the benchmark to say much.
  static constexpr int kMaxDownscale = 4;
  // A reduced depth pixel is kept where its block's depths lie within this
  // fraction of the nearest of them.
  static constexpr float kMaxBlockDepthSpread = 0.05f;

  // Reads the two lists; empty() when either is missing or too short.
  // `downscale` > 1 serves every frame and depth map reduced by that factor
  // (2: 320x240), a real camera at a lower resolution; it must divide 640 and
  // 480 and be at most kMaxDownscale (std::invalid_argument otherwise).
  explicit TumSequence(std::string dataset, int downscale = 1);

  bool empty() const { return rgb_.size() < 3 || depths_.empty(); }
  int frames() const { return static_cast<int>(rgb_.size()); }
  const std::string& dataset() const { return dataset_; }
  int width() const { return kWidth / downscale_; }
  int height() const { return kHeight / downscale_; }

  // Frames [first, first + frames) as a burst (width() x height(), gray and
  // the reference's colour; area-averaged when downscaled), the reference in
  // the middle. Throws std::runtime_error naming a frame it cannot read.
  Burst Window(int first, int frames) const;

  // The Kinect depth in metres (0 = none) nearest in time to the reference of
  // that window. Downscaled, a pixel is the mean of its block of the Kinect's
  // pixels where all of them have depth within kMaxBlockDepthSpread of each
  // other (a block across a depth edge would score the map against a depth no
  // surface has), 0 elsewhere.
  cv::Mat ReferenceDepth(int first, int frames) const;

  // The motion-capture poses (groundtruth.txt: "time tx ty tz qx qy qz qw",
  // the colour camera's centre and orientation in the world) of frames
  // [first, first + frames), relative to the reference in the middle:
  // X_i = R_i X_ref + T_i in metres, each interpolated at its frame's time
  // (linearly, the rotation by slerp). Empty where the sequence has no
  // ground truth or it does not bracket every frame's time.
  std::vector<Pose> TruePoses(int first, int frames) const;

  // `camera`, calibrated at 640x480, for the frames this sequence serves:
  // f and the principal point scaled (ReducedPixel: block centres aligned as
  // cv::resize aligns them), the distortion, on normalized coordinates,
  // unchanged. Throws std::invalid_argument for a camera of another size.
  CameraModel Scaled(CameraModel camera) const;

  // A calibration file of the 640x480 camera (ReadCalibrationFile) for the
  // frames this sequence serves: its camera Scaled, and its lens as the camera;
  // the fit's RMS stays in 640x480 pixels.
  ImportedCalibration ReadCalibration(const std::string& file) const;

 private:
  struct Stamped {
    double time;
    std::string file;
  };
  struct StampedPose {
    double time;
    Eigen::Vector3d centre;
    Eigen::Quaterniond orientation;  // camera to world
  };
  static std::vector<Stamped> ReadList(const std::string& path);
  static std::vector<StampedPose> ReadTrajectory(const std::string& path);
  // The world-from-camera pose at `time`; false outside the trajectory.
  bool PoseAt(double time, Eigen::Vector3d* centre, Eigen::Quaterniond* orientation) const;

  std::string dataset_;
  int downscale_;
  std::vector<Stamped> rgb_, depths_;
  std::vector<StampedPose> trajectory_;
};

}  // namespace dfsm
