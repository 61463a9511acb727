#include "core/pipeline/frame_selection.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <stdexcept>

namespace dfsm {

Burst SelectFrames(const Burst& burst, const std::vector<int>& frames) {
  Burst selected = burst;
  selected.gray.clear();
  selected.manifest.frames.clear();
  selected.source_indices.clear();
  const std::vector<int> indices = burst.frame_indices();
  bool has_reference = false;
  for (const int i : frames) {
    if (i < 0 || i >= burst.size())
      throw std::out_of_range("SelectFrames: no frame " + std::to_string(i));
    if (i == burst.reference()) {
      selected.manifest.reference = selected.size();
      has_reference = true;
    }
    selected.gray.push_back(burst.gray[i]);
    selected.manifest.frames.push_back(burst.manifest.frames[i]);
    selected.source_indices.push_back(indices[i]);
  }
  if (!has_reference) throw std::invalid_argument("SelectFrames: the reference is not selected");
  return selected;
}

Pose PoseAtTime(const std::vector<double>& times, const std::vector<Pose>& poses, double time) {
  if (times.size() != poses.size() || times.size() < 2)
    throw std::invalid_argument("PoseAtTime: needs two poses or more, one per time");
  // The pair that brackets `time`, or the two nearest at either end.
  const size_t after = std::upper_bound(times.begin(), times.end(), time) - times.begin();
  const size_t b = std::clamp<size_t>(after, 1, times.size() - 1), a = b - 1;
  const double w = times[b] > times[a] ? (time - times[a]) / (times[b] - times[a]) : 0.0;
  // R = R_a exp(w log(R_a^T R_b)), T = T_a + w (T_b - T_a).
  const Eigen::AngleAxisd step(poses[a].R.transpose() * poses[b].R);
  Pose pose;
  pose.R = poses[a].R * Eigen::AngleAxisd(w * step.angle(), step.axis()).toRotationMatrix();
  pose.T = poses[a].T + w * (poses[b].T - poses[a].T);
  return pose;
}

}  // namespace dfsm
