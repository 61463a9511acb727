// How a burst's parallax grows frame by frame, measured before any
// reconstruction, so that a capture can take as many frames as its motion
// needs (dfsmd's "frames": "auto") and tell a user who holds the camera too
// still to move it. Rotation moves the view by the homography K R K^-1,
// whatever the depth, and carries none; it is fitted to the tracks (one
// rotation per frame, one focal length for the burst), and the tracks'
// motion beyond it is the parallax the depth map is made of. A homography of
// its own per frame would not do: it also takes out the parallax of any one
// plane (a slanted floor, a wall seen at an angle).
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace dfsm {

struct ParallaxGrowthOptions {
  // Frames are measured scaled down so that their longer side is at most
  // this; the parallax is given in full-resolution pixels.
  int max_side = 640;
  int corners = 300;  // Shi-Tomasi corners of the first frame, at most
  double min_corner_quality = 0.01;
  int klt_window = 21;
  int klt_levels = 3;
  // A step of a track (frame to frame, scaled pixels) whose backward match
  // lands further than this from where it started ends the track.
  double max_forward_backward_px = 0.5;
  // The rotation fit's robust loss (Cauchy) scale, scaled pixels: tracks on
  // a moving object, or mismatched, do not pull the rotation.
  double loss_scale_px = 1.0;
  // Below this many tracks a frame is not measured, nor any after it.
  int min_tracks = 20;
  // Track with the pipeline's tracker (TrackGridedFeatures: from the first
  // frame to each, realigned with gain and bias, full resolution) instead of
  // KLT chained frame to frame on the scaled frames.
  bool pipeline_tracker = false;

  // Throws std::invalid_argument naming the option out of range.
  void Check() const;
};

struct ParallaxGrowth {
  // parallax_px[k]: over the tracks that reach frame k, the median of each
  // one's largest motion beyond the fitted rotation from the first frame,
  // over frames 1..k (full-resolution pixels); [0] is 0. Only the frames up
  // to tracked_frames are measured.
  std::vector<double> parallax_px;
  std::vector<double> parallax_p90_px;  // the same, the 90th percentile
  int tracked_frames = 0;               // the first frames with at least min_tracks tracks
  int tracks = 0;                       // corners found in the first frame
  double focal_px = 0.0;                // the rotation fit's focal length (full resolution)
};

// `gray` in the order a burst would take them (the first is where the burst
// starts: the oldest of the next frames, the newest of the last ones); 8-bit
// single-channel frames of one size.
ParallaxGrowth MeasureParallaxGrowth(const std::vector<cv::Mat>& gray,
                                     const ParallaxGrowthOptions& options = {});

// How many frames a burst takes from a capture of many.
struct BurstLengthOptions {
  int min_frames = 5;
  // A burst is long enough once its parallax reaches this (full-resolution
  // pixels) ...
  double target_parallax_px = 2.0;
  // ... and too still to give depth where even all its frames stay below
  // this.
  double min_parallax_px = 0.5;

  // Throws std::invalid_argument naming the option out of range.
  void Check() const;
};

enum class BurstLengthReason {
  kParallaxReached,  // the fewest frames whose parallax reaches the target
  kMaximumFrames,    // every frame: the target was not reached
  kTracksLost,       // the frames the tracks reach: later frames lost them
  kTooStill,         // every frame, and still below min_parallax_px
};

const char* BurstLengthReasonName(BurstLengthReason reason);

struct BurstLength {
  int frames = 0;
  double parallax_px = 0.0;  // over those frames
  BurstLengthReason reason = BurstLengthReason::kMaximumFrames;
};

BurstLength ChooseBurstLength(const ParallaxGrowth& growth, const BurstLengthOptions& options);

}  // namespace dfsm
