// Rolling shutter in small motion (Im et al., ICCV 2015). A sensor read out
// row by row exposes row v of a frame of height h at
//
//     t(v) = t_frame + readout * ((v + 0.5) / h - 0.5)      (frame intervals),
//
// so a frame's pose (CONTRACT.md: that of its middle row) is not the pose of its
// other rows. Between frames the camera is taken to move along the linear
// interpolation of the burst's own frame poses, in angle-axis and T (exact to
// first order in small motion): a row below the middle moves toward the next
// frame's pose, a row above it toward the previous frame's. The first and last
// frames extrapolate their one neighbour. `readout` 0 is a global shutter; 1
// is a sensor that reads out for the whole frame interval.
//
// Frames are taken one frame interval apart unless `times` (the capture time
// of each frame in frame intervals, increasing; io/frame_times.h reads them
// from a burst) says otherwise: a camera that dropped a frame leaves a gap of
// two intervals, over which the path moves twice as far.
//
// Where a burst's `angular_velocities` are given (one per frame, angle-axis
// per frame interval), a frame's rows turn at its own angular velocity
// instead of along the line to its neighbour (Im et al.'s per-frame
// velocity): a hand's tremor bends the path within a frame, which the line
// between frame poses cannot follow. The translation keeps the line.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "core/camera/pose.h"
#include "core/camera/rolling_shutter_options.h"

namespace dfsm {

// The 6 parameters of a pose as the adjustment holds them: angle-axis of R, then T.
using PoseParameters = Eigen::Matrix<double, 6, 1>;
PoseParameters ToPoseParameters(const Pose& pose);
Pose FromPoseParameters(const PoseParameters& parameters);

// Row v's time offset from its frame's, in frame intervals.
inline double RowTime(double readout, double v, int height) {
  return readout * ((v + 0.5) / height - 0.5);
}

// Throws std::invalid_argument unless `times` is empty or holds one finite,
// strictly increasing time per frame of a burst of `frames`.
void CheckFrameTimes(const std::vector<double>& times, int frames);

// The frame whose pose, with frame i's, sets the path of frame i's rows on
// the side of time offset `dt` (>= 0: the next frame; the first and last
// frames use their one neighbour on both sides). The step per frame interval
// is rate * (P_neighbour - P_i), rate = 1 / (t_neighbour - t_i): +1 for the
// next of consecutive frames, -1 for the previous, +-1/2 across a dropped
// frame. `times`: as above, empty for consecutive frames.
struct Neighbour {
  int frame;
  double rate;
};
Neighbour NeighbourOnSide(int frame, double dt, int frames, const std::vector<double>& times = {});

// The step of frame i's pose parameters per frame interval on the side of time
// offset `dt` (>= 0: toward the next frame), from the burst's frame poses.
class PoseSteps {
 public:
  explicit PoseSteps(const std::vector<Pose>& poses, const std::vector<double>& times = {});
  const PoseParameters& Step(int frame, double dt) const {
    return dt >= 0.0 ? after_[frame] : before_[frame];
  }

 private:
  std::vector<PoseParameters> before_, after_;
};

// Each frame's angular velocity (angle-axis per frame interval); empty: the
// rotation follows the line between frame poses.
using AngularVelocities = std::vector<Eigen::Vector3d>;

// Throws std::invalid_argument unless `velocities` is empty or holds one
// finite velocity per frame of a burst of `frames`.
void CheckAngularVelocities(const AngularVelocities& velocities, int frames);

// The pose of every row of a burst's frames.
class RowPoses {
 public:
  RowPoses(const std::vector<Pose>& poses, double readout, int height,
           const std::vector<double>& times = {}, AngularVelocities velocities = {});

  double readout() const { return readout_; }
  // The pose of row v of frame i.
  Pose At(int frame, double v) const;
  // The pose that maps the camera of row v_ref of frame `reference` to the
  // camera of row v of frame i: X_i = R X_ref + T. With a global shutter,
  // the frame's own pose (the reference's is the identity).
  Pose Relative(int frame, double v, int reference, double v_ref) const;

 private:
  std::vector<PoseParameters> poses_;
  PoseSteps steps_;
  AngularVelocities velocities_;
  double readout_;
  int height_;
};

}  // namespace dfsm
