// What the joint adjustment needs of one burst, kept on disk: dfsmd writes it
// beside each job's result (tracks.cbor) so that a later joint calibration of
// the camera reads tracks, not frames. CBOR (RFC 8949) of one map:
//
//   "format"        "dfsm-tracks/1"
//   "width", "height", "reference"   the image size; the reference frame
//   "camera"        {"f", "cx", "cy", "k1", "k2"}: the burst's own solution
//   "readout"       its rolling-shutter readout, frame intervals
//   "frame_times"   per frame, frame intervals (empty: consecutive)
//   "poses"         per frame [rx, ry, rz, tx, ty, tz]: angle-axis, then T
//   "pixels"        per frame, [u0, v0, u1, v1, ...] of every track (captured pixels)
//   "inverse_depths", "use"   per track: its inverse depth, 1 where an inlier
//   "noise_px", "sigma_f_percent"   the burst's own noise and sigma of f (0: unknown)
//
// 300 tracks over 10 frames take about 60 KB.
#pragma once

#include <filesystem>

#include "core/sparse/joint_adjustment.h"

namespace dfsm {

inline constexpr const char* kJointBurstFormat = "dfsm-tracks/1";

// Writes `burst` atomically. Throws std::runtime_error naming the file.
void WriteJointBurst(const std::filesystem::path& path, const JointBurst& burst);

// Reads a file WriteJointBurst wrote; its name is the file's path. Throws
// std::runtime_error naming the file and what is wrong with it (unreadable,
// not CBOR, another format, a field missing or of the wrong size, a number
// that is not finite).
JointBurst ReadJointBurst(const std::filesystem::path& path);

}  // namespace dfsm
