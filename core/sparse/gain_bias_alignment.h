// Sub-pixel alignment of one patch with a gain and a bias of its own (the
// "linear appearance variation" of Baker & Matthews, IJCV 2004, with one
// brightness basis and a constant): minimizes, over the position p and the
// gain a and bias b,
//
//   sum_w  g(w) ( I(p + w) - a T(w) - b )^2,
//
// where T is the reference patch around its corner, w runs over a square
// window and g is a Gaussian weight. Pyramidal KLT assumes brightness
// constancy; under vignetting, white-balance drift or a gain left over by the
// per-frame compensation a patch's brightness changes with its position, and
// KLT moves the match to where the brightness fits rather than where the
// texture does. Neighbouring tracks share that shift, so the bundle
// adjustment reads it as focal length and distortion
// (docs/experiments/121-gain-bias.md).
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <vector>

namespace dfsm {

struct GainBiasAlignmentOptions {
  // Odd side of the square window in pixels.
  int window = 21;
  // Sigma of the Gaussian weight over the window (px). A uniform window let
  // the gain trade against the shift of edges near its border: ideal bursts
  // lost up to 0.7 points of AbsRel and TUM's self-calibrated f wandered on
  // two windows; sigma 7 in a 21 px window kept both, 3.5 lost the phone
  // bursts' gain (docs/experiments/121-gain-bias.md).
  double weight_sigma_px = 7.0;
  int max_iterations = 20;
  // Stop when a Gauss-Newton step moves the position by less than this (px).
  double epsilon_px = 1e-3;
  // A match that moves further than max(max_shift_px, max_shift_fraction x
  // its displacement from the corner) from its start is not trusted, and its
  // track is dropped. The start is a KLT match that passed the
  // forward-backward check, and a gain explains sub-pixel shifts. But a patch
  // that travelled far is also rotated and sheared (tremor, rolling shutter),
  // and where a translation lands on it depends on the window's weights by an
  // amount that grows with the travel. At 1080p and 2 deg (~80 px) a fixed
  // 0.5 px dropped 60 of 181 tracks and f went 58 % off
  // (docs/experiments/121-gain-bias.md).
  double max_shift_px = 0.5;
  double max_shift_fraction = 0.02;
  // A gain outside (1 / max_gain, max_gain) is a different surface, not the
  // same one seen darker.
  double max_gain = 2.0;

  // Throws std::invalid_argument naming the option out of range.
  void Check() const;
};

// Aligns patches of one reference frame in other frames of the same size.
class GainBiasAligner {
 public:
  // One reference patch and what the normal equations need of it, prepared
  // once for aligning it in every frame.
  struct Patch {
    std::vector<float> intensity;  // T, row-major over the window
    std::vector<float> weighted;   // g Tx, g Ty, g T, g: four arrays of the window's size
    Eigen::Matrix4d sums;          // sum g [Tx Ty T 1]^T [Tx Ty T 1]
    cv::Point2f corner;
  };

  // `reference`: 8-bit gray.
  GainBiasAligner(const cv::Mat& reference, const GainBiasAlignmentOptions& options);

  // Prepares the reference patch around `corner`; false where the window
  // leaves the reference.
  bool Prepare(cv::Point2f corner, Patch* patch) const;

  // Aligns a prepared patch in `image` (8-bit gray, the reference's size),
  // starting from `*position`. Returns false, leaving `*position` as it was,
  // when the window leaves the image, the system is singular, the solve has
  // not converged within max_iterations, or a bound of the options is broken.
  bool Align(const Patch& patch, const cv::Mat& image, cv::Point2f* position) const;
  // The same with the window sampled through `shape` (2x2, row-major): frame
  // position p + shape w for the reference's window offset w, the patch's
  // predicted turn and shear.
  bool Align(const Patch& patch, const cv::Mat& image, const float shape[4],
             cv::Point2f* position) const;

 private:
  // The Gauss-Newton solve from *position; `sums(p, gain, bias)` gives the
  // window's residual against the patch's weighted columns, and `reach` how
  // far the window reaches from p (it must stay inside the image).
  template <class Sums>
  bool Solve(const Patch& patch, const cv::Mat& image, int reach, cv::Point2f* position,
             const Sums& sums) const;

  GainBiasAlignmentOptions options_;
  cv::Mat intensity_, dx_, dy_;  // CV_32F; the derivatives in grey levels per pixel
  std::vector<double> weights_;  // g per window pixel, row-major
};

}  // namespace dfsm
