// Step 2 of the method: the rotation of every frame relative to the reference
// from bearing vectors alone, treating the small baseline as negligible.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "core/camera/camera_model.h"
#include "core/sparse/feature_tracks.h"

namespace dfsm {

// The solver is OpenGV's relative_pose::rotationOnly (Arun's closed form on
// bearing pairs), not Kneip's eigensolver, which also models a translation.
// Measured on simulated 1080p bursts (8 mm baseline, 0.5 deg tremor, 5 seeds,
// mean error over frames): depths 0.7-2.8 m: rotationOnly 0.137 deg,
// eigensolver 0.219-0.239 deg; depths 3-12 m: 0.032 vs 0.042-0.047 deg, with
// 0 and 0.1 px noise alike. At these baselines the translation the eigensolver
// estimates is noise, and fitting it costs rotation accuracy; the rank-1 step
// recovers the translation instead. rotationOnly is also closed-form (no
// starting point, no iterations).
//
// Returns R_i with X_i = R_i X_ref + T_i for every frame (identity for the
// reference). Bearings come from `camera` (the initial guess: f = max(w, h), k = 0).
std::vector<Eigen::Matrix3d> EstimateRotations(const FeatureTracks& tracks,
                                               const CameraModel& camera);

}  // namespace dfsm
