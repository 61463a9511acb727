// The camera motion of a handheld burst: a smooth random wander of the camera
// centre and orientation, the way hand tremor moves a phone over half a second.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <vector>

#include "core/camera/pose.h"

namespace dfsm {

struct CameraPathOptions {
  int frames = 10;
  double baseline = 0.008;    // largest distance between two camera centres
  double rotation_deg = 0.5;  // largest rotation of a frame against the first one
  // Forward motion relative to sideways motion: a hand mostly shakes sideways.
  double forward_fraction = 0.3;
  // A hand's physiological tremor on top of the wander: the orientation
  // oscillates about each axis with up to this amplitude at about
  // oscillation_cycles_per_frame (8-12 Hz at 30 frames a second: 0.27-0.4),
  // so that the camera's turn bends and reverses within a frame's readout as
  // a hand-held one does (docs/experiments/021; the frame poses move too).
  // 0: the wander alone.
  double oscillation_deg = 0.0;
  double oscillation_cycles_per_frame = 0.33;
  // Between frames (a rolling shutter's rows, a blurred exposure): the line
  // between the frame poses (linear in the centre and in the rotation's
  // angle-axis, extrapolated beyond the ends; the rolling-shutter model of
  // core/camera/rolling_shutter.h), or the hand's own path, which curves and,
  // with the oscillation, bends within a frame. The frames' poses are the
  // same either way.
  enum class BetweenFrames { kLine, kHand };
  BetweenFrames between_frames = BetweenFrames::kLine;
  uint64_t seed = 1;
};

// The camera's motion as a function of time t in frame intervals, frame i at
// t = i, as CameraPathOptions::between_frames says. Frame 0 is at the
// identity. Deterministic for given options.
class HandheldPath {
 public:
  explicit HandheldPath(const CameraPathOptions& options);
  Pose At(double t) const;  // X_t = R X_0 + T
  // One pose per frame: At(0), ..., At(frames - 1).
  std::vector<Pose> FramePoses() const;

 private:
  class Wander;
  struct Oscillation {
    double amplitude, cycles_per_frame, phase;  // radians, -, radians
  };
  Eigen::Vector3d Angles(double t) const;
  Eigen::Vector3d Centre(double t) const;
  Pose HandAt(double t) const;
  Pose LineAt(double t) const;

  CameraPathOptions options_;
  std::shared_ptr<const Wander> position_, orientation_;
  double position_scale_ = 0.0, angle_scale_ = 0.0;
  Oscillation oscillation_[3] = {};
  std::vector<Pose> frames_;
};

// HandheldPath(options).FramePoses().
std::vector<Pose> HandheldCameraPath(const CameraPathOptions& options);

// The same motion with frame `reference` as the reference: pose i becomes
// pose_i * pose_reference^-1 (X_i = R_i R_r^T X_r + T_i - R_i R_r^T T_r), so
// that the reference is at the identity and every pair of frames keeps its
// relative pose.
std::vector<Pose> PosesRelativeTo(const std::vector<Pose>& poses, int reference);

}  // namespace dfsm
