// Step 2 of the method: the rotation of every frame relative to the reference
// from bearing vectors alone, treating the small baseline as negligible.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "core/camera/camera_model.h"
#include "core/sparse/feature_tracks.h"

namespace dfsm {

enum class RotationSolver {
  // OpenGV relative_pose::rotationOnly (Arun's closed form on bearing pairs).
  // Default: on small baselines it measured 0.04-0.05 deg error against
  // 0.05-0.16 deg for the eigensolver (PITFALLS.md), and it is closed-form.
  kRotationOnly,
  // OpenGV relative_pose::eigensolver (Kneip & Lynen 2013), which also models a
  // translation; kept for comparison.
  kEigensolver,
};

// Returns R_i with X_i = R_i X_ref + T_i for every frame (identity for the
// reference). Bearings come from `camera` (the initial guess: f = max(w, h), k = 0).
std::vector<Eigen::Matrix3d> EstimateRotations(
    const FeatureTracks& tracks, const CameraModel& camera,
    RotationSolver solver = RotationSolver::kRotationOnly);

}  // namespace dfsm
