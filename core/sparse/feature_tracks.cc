#include "core/sparse/feature_tracks.h"

#include <algorithm>

namespace dfsm {

int CountUsed(const std::vector<bool>& use) {
  return static_cast<int>(std::count(use.begin(), use.end(), true));
}

FeatureTracks FeatureTracks::Select(const std::vector<bool>& keep) const {
  FeatureTracks selected;
  selected.reference = reference;
  const int kept = CountUsed(keep);
  for (const Eigen::Matrix2Xd& frame : pixels) {
    Eigen::Matrix2Xd out(2, kept);
    for (int j = 0, k = 0; j < frame.cols(); ++j)
      if (keep[j]) out.col(k++) = frame.col(j);
    selected.pixels.push_back(std::move(out));
  }
  if (!weights.empty())
    for (size_t j = 0; j < weights.size(); ++j)
      if (keep[j]) selected.weights.push_back(weights[j]);
  return selected;
}

double FeatureTracks::MedianMaxDisplacement() const {
  std::vector<double> displacement(num_tracks(), 0.0);
  for (int i = 0; i < num_frames(); ++i)
    for (int j = 0; j < num_tracks(); ++j)
      displacement[j] =
          std::max(displacement[j], (pixels[i].col(j) - pixels[reference].col(j)).norm());
  if (displacement.empty()) return 0.0;
  std::nth_element(displacement.begin(), displacement.begin() + displacement.size() / 2,
                   displacement.end());
  return displacement[displacement.size() / 2];
}

}  // namespace dfsm
