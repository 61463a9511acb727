// How far a burst's relief depends on the camera it was placed with
// (SparseReconstruction::camera_relief_disagreement,
// docs/experiments/016-camera-relief-disagreement.md).
#pragma once

#include <vector>

namespace dfsm {

// Two solutions of the same tracks, each with its own camera: the median,
// over the tracks both keep (`use_a`, `use_b`) on the same side of the
// camera in both, of |w_b / (s w_a) - 1|, where s is the median of
// w_b / w_a (a common scale is free; what is left is relief). -1 where
// fewer than two tracks compare.
double CameraReliefDisagreement(const std::vector<double>& inverse_depths_a,
                                const std::vector<bool>& use_a,
                                const std::vector<double>& inverse_depths_b,
                                const std::vector<bool>& use_b);

}  // namespace dfsm
