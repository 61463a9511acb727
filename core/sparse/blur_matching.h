// Tracking under motion blur by matching the blurs: a frame smeared by the
// camera's motion during its exposure is compared with the reference blurred
// the same way, and the reference's own smear is put on the frame. With a
// blur kernel K_i per frame, frame i is S_i * K_i and the reference S * K_ref,
// so (S * K_ref) * K_i and (S_i * K_i) * K_ref show the same scene through
// the same blur wherever S_i is S moved: KLT and the gain-bias realignment
// then compare like with like, where a sharp template against a smeared
// frame leaves no clean minimum and the match is dropped (the approach of
// Park, Lepetit and Woo, "ESM-Blur", ISMAR 2009, with the blur from the
// tracked motion instead of per-patch parameters).
//
// K_i is a line segment centred on the frame's time, along the image motion
// at the image centre, as long as that motion over the open shutter: the
// exposure fraction times the frame's velocity (px per frame interval), the
// velocity read from the homographies fitted to the frame's tracks. The
// exposure fraction is not known; the tracker tries several and keeps the
// one whose matches survive best.
#pragma once

#include <opencv2/core.hpp>
#include <optional>
#include <vector>

namespace dfsm {

struct BlurMatchingOptions {
  bool enabled = true;
  // The shutter's open time as fractions of the frame interval to try.
  std::vector<double> exposure_fractions = {0.3, 0.6, 1.0};
  // A frame is tracked again with matched blurs where its blur and the
  // reference's differ by at least this (px) at the largest fraction tried:
  // below it the blurs cost a sharp match nothing.
  double min_blur_difference_px = 1.0;

  // Throws std::invalid_argument naming the option out of its range.
  void Check() const;
};

// The normalized kernel of a blur along `velocity` (px per frame interval)
// over `exposure_fraction` of the interval, centred: a line segment with
// bilinear ends. 1x1 (identity) where the segment is shorter than 0.1 px.
cv::Mat MotionBlurKernel(cv::Point2d velocity, double exposure_fraction);

// How far apart two line blurs of the given velocities are over a shutter
// open for one frame interval (px): a segment along v and along -v is the
// same blur, so the nearer of v_a - v_b and v_a + v_b.
double BlurDifference(cv::Point2d velocity_a, cv::Point2d velocity_b);

// Each frame's image velocity at `point` (px per frame interval) from the
// homographies mapping the reference into each frame (`motion`, the
// reference's the identity), by central differences inside the burst and
// one-sided at its ends; none where a neighbour's homography is missing.
// Frames are taken as equally spaced in time.
std::vector<std::optional<cv::Point2d>> FrameVelocities(
    const std::vector<std::optional<cv::Matx33d>>& motion, cv::Point2f point);

}  // namespace dfsm
