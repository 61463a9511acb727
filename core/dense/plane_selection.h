// Winner-take-all over a cost volume with sub-plane parabolic refinement and
// a per-pixel confidence.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace dfsm {

struct PlaneSelection {
  cv::Mat plane;       // CV_32FC1, fractional lattice index of the winner; -1 = no cost at all
  cv::Mat confidence;  // CV_32FC1 in [0, 1]
  cv::Mat at_edge;     // CV_8UC1, 255 where the winner is the first or last slice
};

// `costs[k]` is the slice of lattice plane first_plane + k * stride
// (first_plane: CV_32SC1, or empty for 0). The confidence is the distinctiveness of the
// winner's basin: 1 - c_best / c_rival, where c_rival is the lowest cost
// outside the valley that descends to the winner (the cost of the most
// competitive other depth). A flat or multi-modal curve scores near 0; a curve
// with no rival valley scores against its largest cost.
PlaneSelection SelectPlanes(const std::vector<cv::Mat>& costs, const cv::Mat& first_plane = {},
                            int stride = 1);

// The winner of one cost curve of n planes, as SelectPlanes selects it at
// each pixel: plane = first + (best + sub-plane offset) * stride (-1 when no
// plane has a cost), its confidence and edge flag (255 or 0).
void SelectCurve(const float* curve, int n, int first, int stride, float* plane, float* confidence,
                 uchar* at_edge);

// The same into `selection`, whose three Mats already have the slices' size
// and types (views into larger images are fine): the plane sweep selects band
// by band into the full-size result, so no band needs a copy.
void SelectPlanesInto(const std::vector<cv::Mat>& costs, const cv::Mat& first_plane, int stride,
                      PlaneSelection* selection);

// A prior on the winner of a window of planes: the curve of every pixel gets
// weight x (k - k_seed)^2 added before the winner is selected, k_seed =
// (seed - first_plane) / stride the seed's fractional slice. The winner is
// then the maximum a posteriori plane under a Gaussian prior around the seed
// (for a cost that is quadratic near its minimum): where the photo-
// consistency is sharp it decides; where it is shallow (weak texture, noise)
// the seed does. The edge flag is the photo-consistency's alone (its own
// minimum on the window's first or last slice: the minimum may lie beyond
// the window), so a miss is still told; the winner and its confidence are
// those of the drawn curve.
struct SeedPrior {
  cv::Mat seed;         // CV_32FC1, fractional lattice index, the costs' size
  float weight = 0.0f;  // cost per squared slice offset; 0: no prior
};

// SelectPlanesInto with the winners drawn towards `prior.seed` (see SeedPrior).
void SelectPlanesNearSeedInto(const std::vector<cv::Mat>& costs, const cv::Mat& first_plane,
                              int stride, const SeedPrior& prior, PlaneSelection* selection);

// The confidence of given winners (plane: CV_32FC1 index into `costs`,
// rounded; -1 for none) on the curves of `costs`: the confidence SelectPlanes
// gives the minimum of the valley that holds the winner (found by walking
// down the curve), where that minimum lies within `reach` planes of the
// winner, and 0 where it does not. Semi-global aggregation picks a pixel's
// winner by its neighbours where its own curve is flat or ambiguous; this
// says how much the photo-consistency alone supports that choice, allowing
// for the step the neighbours move it by within reach of the search that
// refines it.
// `valley_cost`, when given, receives the cost at that minimum (kNoCost where
// the confidence is 0 for want of one).
cv::Mat ConfidenceOfPlanes(const std::vector<cv::Mat>& costs, const cv::Mat& plane, int reach,
                           cv::Mat* valley_cost = nullptr);

// Photo-consistency outliers: sets `confidence` to 0 where `cost` (CV_32FC1,
// each pixel's own cost at its chosen depth, kNoCost for none) exceeds
// max_ratio times the median cost of the pixels of like texture (the
// reference's mean gradient magnitude over the cost's window of
// window_radius; the pixels in classes of equal size). A correct match costs
// more where the texture is stronger (interpolation error and signal-dependent
// noise grow with it), so each pixel is held to what its own kind of texture
// costs in this burst, and no absolute level is assumed. Returns the number
// of pixels it zeroed.
// `rejected`, when given, receives CV_8UC1 255 where it zeroed (0 elsewhere).
// A class whose median is below kMinOutlierCostScale (frames identical there:
// clipped black or white) is held to that instead.
int RejectCostOutliers(const cv::Mat& cost, const cv::Mat& reference, int window_radius,
                       double max_ratio, cv::Mat* confidence, cv::Mat* rejected = nullptr);

// Grey levels of mean truncated difference: below the noise of any camera.
inline constexpr float kMinOutlierCostScale = 0.1f;

}  // namespace dfsm
