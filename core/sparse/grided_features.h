// Step 1 of the method: grided Shi-Tomasi corners on the reference frame,
// tracked to every frame with pyramidal KLT and a forward-backward check.
//
// One corner per fixed cell (instead of the ~2000 strongest corners of Ha et
// al.) spreads the tracks evenly and bounds their number, which is what keeps
// the rank-1 factorization and bundle adjustment cheap.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "core/sparse/feature_tracks.h"

namespace dfsm {

struct GridedFeatureOptions {
  // Cell side in pixels; 0 = 80 px at 1080p, scaled with the shorter image side.
  int cell_px = 0;
  // A cell's corner must reach this fraction of the strongest corner response.
  double min_quality = 0.01;
  int klt_window = 21;
  int klt_levels = 3;
  // Largest forward-backward distance (px) for a track to be kept.
  double max_forward_backward_px = 0.3;
};

int GridCellSize(const GridedFeatureOptions& options, int width, int height);

struct GridedFeatureStats {
  int cells = 0;
  int corners = 0;  // cells with a corner strong enough to track
  int tracks = 0;   // corners tracked to every frame and passing the check
};

// Detects one corner per cell of `frames[reference]` and tracks it to every
// frame. Frames are 8-bit gray of one size. Tracks lost in any frame are dropped.
FeatureTracks TrackGridedFeatures(const std::vector<cv::Mat>& frames, int reference,
                                  const GridedFeatureOptions& options = {},
                                  GridedFeatureStats* stats = nullptr);

// The detection half alone: the strongest Shi-Tomasi corner of each cell.
std::vector<cv::Point2f> DetectGridedCorners(const cv::Mat& gray, int cell_px, double min_quality,
                                             int border_px);

}  // namespace dfsm
