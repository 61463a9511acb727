// The camera motion of a handheld burst: a smooth random wander of the camera
// centre and orientation, the way hand tremor moves a phone over half a second.
#pragma once

#include <cstdint>
#include <vector>

#include "core/camera/pose.h"

namespace dfsm {

struct CameraPathOptions {
  int frames = 10;
  double baseline = 0.008;    // largest distance between two camera centres
  double rotation_deg = 0.5;  // largest rotation of a frame against the first one
  // Forward motion relative to sideways motion: a hand mostly shakes sideways.
  double forward_fraction = 0.3;
  uint64_t seed = 1;
};

// One pose per frame (X_i = R_i X_ref + T_i); frame 0 is the reference, at the
// identity. Deterministic for given options.
std::vector<Pose> HandheldCameraPath(const CameraPathOptions& options);

// The same motion with frame `reference` as the reference: pose i becomes
// pose_i * pose_reference^-1 (X_i = R_i R_r^T X_r + T_i - R_i R_r^T T_r), so
// that the reference is at the identity and every pair of frames keeps its
// relative pose.
std::vector<Pose> PosesRelativeTo(const std::vector<Pose>& poses, int reference);

}  // namespace dfsm
