// Step 1 of the method: grided Shi-Tomasi corners on the reference frame,
// tracked to every frame with pyramidal KLT and a forward-backward check.
//
// One corner per fixed cell (instead of the ~2000 strongest corners of Ha et
// al.) spreads the tracks evenly and bounds their number, which is what keeps
// the rank-1 factorization and bundle adjustment cheap.
#pragma once

#include <array>
#include <opencv2/core.hpp>
#include <vector>

#include "core/io/progress.h"
#include "core/sparse/feature_tracks.h"
#include "core/sparse/gain_bias_alignment.h"

namespace dfsm {

struct GridedFeatureOptions {
  // Cell side in pixels; 0 = 80 px at 1080p, scaled with the shorter image
  // side. dfsm and dfsmd accept up to kMaxCellPx.
  static constexpr int kMaxCellPx = 4096;
  int cell_px = 0;
  // A cell's corner must reach this fraction of the strongest corner response
  // in the image: a floor above noise, not a bar for texture. At 0.01 a weakly
  // textured background beside high-contrast objects lost most of its cells
  // (98 tracks where 0.003 keeps 230, generated 640x480 burst, seed 1): the
  // rotations were off by 0.065 deg and the whole pipeline's depth by 9.2 %
  // AbsRel; at 0.003 with the 0.2 px check below: 0.006 deg, 1.1 %
  // (docs/experiments/103-weak-texture-corners.md).
  double min_quality = 0.003;
  int klt_window = 21;
  int klt_levels = 3;
  // Largest forward-backward distance (px) for a track to be kept. 0.2, not
  // 0.3: the weak corners that min_quality now admits track less precisely,
  // and at 2 deg of VGA tremor they cost up to 0.75 points of focal accuracy
  // at 0.3 px (seed 1: 0.41 -> 1.16 %), 0.5 at 0.2 px (0.91 %).
  double max_forward_backward_px = 0.2;
  // ... or this fraction of the track's travel where that is more. KLT
  // moves a translation, and a patch that travelled far has also turned and
  // sheared (the roll, and a rolling shutter, under a tremor of 1-2 deg), so
  // its forward and backward matches part by more the further it went: at
  // 1080p and 2 deg (50-77 px of travel) the 0.2 px bound alone left 26 of
  // 336 tracks on one burst (docs/experiments/134-patch-shape.md).
  // 0.008: 0.2 px up to 25 px of travel, 0.6 px at 75 px; the realignment
  // through the patch's shape (below) then decides.
  double max_forward_backward_fraction = 0.008;
  // Each match that passes the check is realigned at full resolution with a
  // gain and a bias of its own (gain_bias_alignment.h; its window is
  // klt_window, which overrides alignment.window and must be odd), and
  // dropped where that fails. Off, vignetting and
  // white-balance drift moved f by 8-23 % on the generator's phone and webcam
  // bursts at 640x480 (docs/experiments/121-gain-bias.md).
  bool gain_bias = true;
  // The realignment samples each patch as the frame's motion turned and
  // sheared it: the Jacobian, at the corner, of the homography that fits the
  // frame's KLT matches (PatchShape). A translation alone lands tenths of a
  // pixel off a patch turned by 3 deg (gain_bias_alignment_test).
  bool predicted_shape = true;
  // ... where the shape moves the window's corners by this much (px) or more
  // against a translation (a roll of 0.5 deg moves them 0.09 px).
  double min_shape_px = 0.1;
  GainBiasAlignmentOptions alignment;
  // A frame is left out of the tracks where keeping it would lose more than
  // this share of the tracks that every other frame keeps: one frame of blur
  // or a jolt then costs that frame, not the burst. Hand-held real bursts
  // lose their tracks at one end or both (tum_fr1_rpy: 4-25 of 90 tracks
  // reach a window's end frames). Two thirds, not one half: the poses' noise
  // grows as one over the root of the tracks, 1.7x with a third of them,
  // more than an end frame's share of the baseline gives back; at one half a
  // window whose first frame kept 43 of 87 tracks lost its depth (24.9 ->
  // 287 % AbsRel) and a generated 320x240 burst five of ten frames
  // (docs/experiments/141-frames-left-out.md). 1: no frame is left out.
  double max_frame_track_loss = 2.0 / 3.0;
  // ... while at least this share of the frames (and 3) stay.
  double min_frame_share = 0.5;
  // A frame is also left out where keeping it would leave the frames kept
  // sharing fewer tracks than this (the sparse stage: twice its min_tracks,
  // room for the adjustment's rejections). The loss
  // bound is a share of what the frames kept so far share, so blurred frames
  // in a row, each within it, compound to fewer tracks than a burst needs
  // where the frames that track well would have given one: tum_fr1_rpy
  // window 13 kept 8 tracks through 8 frames, and has 40 through the 5 that
  // track (docs/experiments/018-frames-kept-above-the-track-floor.md).
  // 0: no floor.
  int min_shared_tracks = 0;
  // Hears "features" after the detection and after each tracked frame.
  ProgressCallback progress;

  // Throws std::invalid_argument naming the option out of its range.
  void Check() const;
};

// At most this many grid cells: the tracks, the adjustment's size and its
// memory grow with the cells, and `grid=1` at 1280x960 (1.2 M cells) took
// 86 s and 1.5 GB. 8192 cells allow a 15 px grid at 1080p, 5x the default's.
inline constexpr int kMaxGridCells = 8192;

// The smallest cell side that keeps a width x height image within
// kMaxGridCells.
int MinGridCellSize(int width, int height);

// The cell side used: options.cell_px (0: 80 px at 1080p, scaled), raised to
// MinGridCellSize.
int GridCellSize(const GridedFeatureOptions& options, int width, int height);

struct GridedFeatureStats {
  int cells = 0;
  int corners = 0;  // cells with a corner strong enough to track
  int tracks = 0;   // corners tracked to every frame and passing the check
  // Per frame: the corners KLT found there and kept through the
  // forward-backward check and the realignment (the reference: every corner
  // whose patch could be prepared), before a track needs all frames. A frame far below the others
  // is the one that loses the tracks (blur, a jolt).
  std::vector<int> reached;
  // The frames the tracks run through (indices into the frames given,
  // ascending, the reference among them): every frame but those left out.
  std::vector<int> kept_frames;
  // A frame left out (GridedFeatureOptions::max_frame_track_loss): the
  // tracks the frames kept share, and those of them that reach it.
  struct LeftOut {
    int frame = 0;
    int tracks_without = 0;
    int tracks_with = 0;
  };
  std::vector<LeftOut> left_out;
};

// Detects one corner per cell of `frames[reference]` and tracks it to every
// frame. Frames are 8-bit gray of one size. A frame that would cost most of
// the tracks is left out (stats->left_out); the tracks returned run through
// the other frames (stats->kept_frames, in that order, their reference the
// given one's place among them), and a track lost in any of those is dropped.
FeatureTracks TrackGridedFeatures(const std::vector<cv::Mat>& frames, int reference,
                                  const GridedFeatureOptions& options = {},
                                  GridedFeatureStats* stats = nullptr);

// The frames to leave out given which tracks reached which frame
// (reached[frame][track], after every check). Starting from the reference,
// frames join in the order of how many tracks reach them (the nearer the
// reference the earlier among equals), each unless it would cut the tracks
// the frames kept so far share by more than options.max_frame_track_loss, or
// below options.min_shared_tracks.
// Where fewer than options.min_frame_share of the frames (and 3) are kept,
// those that keep the most tracks join until there are; then each frame left
// out joins if it keeps enough of what remains. Never the reference. Each
// frame left out reports the tracks the kept frames share, and how many of
// them reach it.
std::vector<GridedFeatureStats::LeftOut> FramesToLeaveOut(
    const std::vector<std::vector<uchar>>& reached, int reference,
    const GridedFeatureOptions& options);

// How the patch around `corner` maps into a frame whose motion is the
// homography H: H's Jacobian at the corner, row-major (GainBiasAligner's
// shape).
std::array<float, 4> PatchShape(const cv::Matx33d& H, cv::Point2f corner);

// The Shi-Tomasi response of every pixel: cv::cornerMinEigenVal(gray, 3, 3)
// computed in bands of rows on OpenCV's pool (the same values but for the
// rounding of its running box sums: 5e-10 at 2 of 2 million pixels of a
// 1080p frame whose strongest response is 0.019: only a near-tie within that
// rounding, between a cell's two best or at the quality cut, could change a
// corner). The call on the whole
// frame runs on one core and allocates ~48 MB of temporaries at 1080p; it
// took 66 ms there against 10-16 ms in 64-row bands.
cv::Mat CornerResponse(const cv::Mat& gray);

// The detection half alone: the strongest Shi-Tomasi corner of each cell.
std::vector<cv::Point2f> DetectGridedCorners(const cv::Mat& gray, int cell_px, double min_quality,
                                             int border_px);

}  // namespace dfsm
