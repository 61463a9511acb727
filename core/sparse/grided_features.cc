#include "core/sparse/grided_features.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>
#include <optional>
#include <stdexcept>

#include "core/parallel/parallel_for.h"

namespace dfsm {

void GridedFeatureOptions::Check() const {
  if (!(cell_px >= 0 && cell_px <= kMaxCellPx))
    throw std::invalid_argument("cell_px must be 0 (automatic) to " + std::to_string(kMaxCellPx) +
                                ", got " + std::to_string(cell_px));
  if (!(min_quality > 0.0 && min_quality < 1.0))
    throw std::invalid_argument("min_quality must be in (0, 1), got " +
                                std::to_string(min_quality));
  if (!(klt_window >= 3 && klt_window % 2 == 1))
    throw std::invalid_argument("klt_window must be odd and >= 3, got " +
                                std::to_string(klt_window));
  if (!(klt_levels >= 0 && klt_levels <= 8))
    throw std::invalid_argument("klt_levels must be 0 to 8, got " + std::to_string(klt_levels));
  if (!(max_forward_backward_px > 0.0))
    throw std::invalid_argument("max_forward_backward_px must be > 0");
  if (!(max_forward_backward_fraction >= 0.0))
    throw std::invalid_argument("max_forward_backward_fraction must be >= 0");
  if (!(min_shape_px >= 0.0)) throw std::invalid_argument("min_shape_px must be >= 0");
  if (!(max_frame_track_loss > 0.0 && max_frame_track_loss <= 1.0))
    throw std::invalid_argument("max_frame_track_loss must be in (0, 1], got " +
                                std::to_string(max_frame_track_loss));
  if (!(min_frame_share >= 0.0 && min_frame_share <= 1.0))
    throw std::invalid_argument("min_frame_share must be in [0, 1], got " +
                                std::to_string(min_frame_share));
  if (!(min_shared_tracks >= 0))
    throw std::invalid_argument("min_shared_tracks must be >= 0, got " +
                                std::to_string(min_shared_tracks));
  alignment.Check();
}

int MinGridCellSize(int width, int height) {
  const double area = static_cast<double>(width) * static_cast<double>(height);
  return std::max(1, static_cast<int>(std::ceil(std::sqrt(area / kMaxGridCells))));
}

int GridCellSize(const GridedFeatureOptions& options, int width, int height) {
  const int cell =
      options.cell_px > 0
          ? options.cell_px
          : std::max(8, static_cast<int>(std::lround(80.0 * std::min(width, height) / 1080.0)));
  return std::max(cell, MinGridCellSize(width, height));
}

cv::Mat CornerResponse(const cv::Mat& gray) {
  CV_Assert(gray.type() == CV_8UC1);
  // A band reads one row beyond each of its rows for the 3x3 block sum of
  // the gradients' products, and the 3x3 Sobel one more. At the frame's own
  // top and bottom the band's border is the frame's.
  constexpr int kBlockSize = 3, kSobelSize = 3, kBandRows = 64;
  cv::Mat response(gray.size(), CV_32FC1);
  ForEachRowBand(gray.rows, kBandRows, kBlockSize / 2 + kSobelSize / 2, [&](const RowBand& band) {
    cv::Mat band_response;
    cv::cornerMinEigenVal(gray.rowRange(band.from, band.to), band_response, kBlockSize, kSobelSize);
    band_response.rowRange(band.Own()).copyTo(response.rowRange(band.first, band.last));
  });
  return response;
}

std::vector<cv::Point2f> DetectGridedCorners(const cv::Mat& gray, int cell_px, double min_quality,
                                             int border_px) {
  const cv::Mat response = CornerResponse(gray);
  double strongest = 0.0;
  cv::minMaxLoc(response, nullptr, &strongest);
  const float threshold = static_cast<float>(min_quality * strongest);

  std::vector<cv::Point2f> corners;
  for (int y0 = 0; y0 < gray.rows; y0 += cell_px) {
    for (int x0 = 0; x0 < gray.cols; x0 += cell_px) {
      // Corners near the border cannot be tracked with a full KLT window.
      const cv::Rect cell =
          cv::Rect(x0, y0, cell_px, cell_px) &
          cv::Rect(border_px, border_px, gray.cols - 2 * border_px, gray.rows - 2 * border_px);
      if (cell.area() <= 0) continue;
      double best = 0.0;
      cv::Point location;
      cv::minMaxLoc(response(cell), nullptr, &best, nullptr, &location);
      if (best <= threshold || best <= 0.0) continue;
      corners.emplace_back(static_cast<float>(cell.x + location.x),
                           static_cast<float>(cell.y + location.y));
    }
  }
  return corners;
}

namespace {

// The homography least-squares fitted to the matches of the corners kept in
// one frame (`kept`): the frame's motion, a rotation's exactly, the
// parallax's not (a few pixels over a burst, of which a patch's shape sees
// nothing). None with fewer than 8 matches or where the fit fails.
std::optional<cv::Matx33d> FitFrameMotion(const std::vector<cv::Point2f>& corners,
                                          const std::vector<cv::Point2f>& positions,
                                          const std::vector<uchar>& kept) {
  std::vector<cv::Point2f> from, to;
  for (size_t j = 0; j < corners.size(); ++j)
    if (kept[j]) from.push_back(corners[j]), to.push_back(positions[j]);
  if (from.size() < 8) return std::nullopt;
  const cv::Mat H = cv::findHomography(from, to, 0);
  if (H.empty()) return std::nullopt;
  return cv::Matx33d(H);
}

// Whether `shape` moves the window's corners by min_shape_px or more against
// a translation. Below that the translation samples the window with one
// sub-pixel phase, one blur for every pixel, which the shape's samples,
// each with a phase of its own, would trade for a deformation they do not see.
bool ShapeMovesTheWindow(const std::array<float, 4>& shape, const GridedFeatureOptions& options) {
  const double half = options.klt_window / 2;
  const double moved = half * std::max(std::abs(shape[0] - 1.0f) + std::abs(shape[1]),
                                       std::abs(shape[2]) + std::abs(shape[3] - 1.0f));
  return moved >= options.min_shape_px;
}

}  // namespace

std::array<float, 4> PatchShape(const cv::Matx33d& H, cv::Point2f corner) {
  const double X = H(0, 0) * corner.x + H(0, 1) * corner.y + H(0, 2);
  const double Y = H(1, 0) * corner.x + H(1, 1) * corner.y + H(1, 2);
  const double Z = H(2, 0) * corner.x + H(2, 1) * corner.y + H(2, 2);
  const double z2 = Z * Z;
  return {static_cast<float>((H(0, 0) * Z - X * H(2, 0)) / z2),
          static_cast<float>((H(0, 1) * Z - X * H(2, 1)) / z2),
          static_cast<float>((H(1, 0) * Z - Y * H(2, 0)) / z2),
          static_cast<float>((H(1, 1) * Z - Y * H(2, 1)) / z2)};
}

std::vector<GridedFeatureStats::LeftOut> FramesToLeaveOut(
    const std::vector<std::vector<uchar>>& reached, int reference,
    const GridedFeatureOptions& options) {
  const int n = static_cast<int>(reached.size());
  const int m = n > 0 ? static_cast<int>(reached[0].size()) : 0;
  const int min_frames =
      std::min(n, std::max(3, static_cast<int>(std::ceil(options.min_frame_share * n - 1e-9))));
  std::vector<uchar> shared = reached[reference], kept(n, 0);
  kept[reference] = 1;
  const auto count = [&](int frame) {  // the shared tracks that reach `frame`
    int c = 0;
    for (int j = 0; j < m; ++j) c += shared[j] && reached[frame][j];
    return c;
  };
  const auto keep = [&](int frame) {
    for (int j = 0; j < m; ++j) shared[j] = shared[j] && reached[frame][j];
    kept[frame] = 1;
  };
  const auto keeps_enough = [&](int frame) {
    const int before = static_cast<int>(std::count(shared.begin(), shared.end(), 1));
    const int after = count(frame);
    return after >= (1.0 - options.max_frame_track_loss) * before &&
           after >= options.min_shared_tracks;
  };
  // The frames most tracks reach first, the nearer the reference the earlier
  // among equals.
  std::vector<int> order;
  for (int i = 0; i < n; ++i)
    if (i != reference) order.push_back(i);
  std::vector<int> reach(n);
  for (int i = 0; i < n; ++i)
    reach[i] = static_cast<int>(std::count(reached[i].begin(), reached[i].end(), 1));
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return reach[a] != reach[b] ? reach[a] > reach[b]
                                : std::abs(a - reference) < std::abs(b - reference);
  });
  for (const int i : order)
    if (keeps_enough(i)) keep(i);
  // Too few frames: the ones that keep the most tracks join, one at a time;
  // then every frame left out that now keeps enough of what remains.
  for (int frames = static_cast<int>(std::count(kept.begin(), kept.end(), 1)); frames < min_frames;
       ++frames) {
    int best = -1, best_count = -1;
    for (const int i : order)
      if (!kept[i] && count(i) > best_count) best = i, best_count = count(i);
    keep(best);
  }
  for (const int i : order)
    if (!kept[i] && keeps_enough(i)) keep(i);
  const int tracks = static_cast<int>(std::count(shared.begin(), shared.end(), 1));
  std::vector<GridedFeatureStats::LeftOut> left_out;
  for (int i = 0; i < n; ++i)
    if (!kept[i]) left_out.push_back({i, tracks, count(i)});
  return left_out;
}

FeatureTracks TrackGridedFeatures(const std::vector<cv::Mat>& frames, int reference,
                                  const GridedFeatureOptions& options, GridedFeatureStats* stats) {
  CV_Assert(!frames.empty() && reference >= 0 && reference < static_cast<int>(frames.size()));
  const cv::Mat& ref = frames[reference];
  const int cell = GridCellSize(options, ref.cols, ref.rows);
  const std::vector<cv::Point2f> corners =
      DetectGridedCorners(ref, cell, options.min_quality, options.klt_window / 2 + 1);
  // The steps: the detection, each other frame's tracking, the alignment.
  const int steps = static_cast<int>(frames.size()) + 1;
  ReportProgress(options.progress, "features", 1, steps);

  const cv::Size window(options.klt_window, options.klt_window);
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01);
  std::vector<cv::Mat> ref_pyramid;
  cv::buildOpticalFlowPyramid(ref, ref_pyramid, window, options.klt_levels, true);

  const int n = static_cast<int>(frames.size());
  const int m = static_cast<int>(corners.size());
  std::vector<std::vector<cv::Point2f>> positions(n);
  std::vector<std::vector<uchar>> valid(n, std::vector<uchar>(m, 0));
  positions[reference] = corners;
  std::fill(valid[reference].begin(), valid[reference].end(), 1);

  // Every frame is tracked directly from the reference (no drift accumulates),
  // starting from the positions found in its neighbour nearer the reference:
  // consecutive frames differ by a pixel or so, so the pyramid search converges
  // in a couple of iterations per level. OpenCV spreads the points over cores.
  std::vector<int> order;
  for (int d = 1; d < n; ++d) {
    if (reference + d < n) order.push_back(reference + d);
    if (reference - d >= 0) order.push_back(reference - d);
  }
  std::vector<cv::Mat> pyramid;
  int tracked_frames = 0;
  for (const int i : order) {
    if (m == 0) break;
    const int neighbour = i > reference ? i - 1 : i + 1;
    cv::buildOpticalFlowPyramid(frames[i], pyramid, window, options.klt_levels, true);
    std::vector<cv::Point2f> forward = positions[neighbour], backward = corners;
    std::vector<uchar> status_forward, status_backward;
    std::vector<float> error;
    cv::calcOpticalFlowPyrLK(ref_pyramid, pyramid, corners, forward, status_forward, error, window,
                             options.klt_levels, criteria, cv::OPTFLOW_USE_INITIAL_FLOW);
    cv::calcOpticalFlowPyrLK(pyramid, ref_pyramid, forward, backward, status_backward, error,
                             window, options.klt_levels, criteria, cv::OPTFLOW_USE_INITIAL_FLOW);
    for (int j = 0; j < m; ++j) {
      const cv::Point2f d = backward[j] - corners[j];
      const bool inside = forward[j].x >= 0 && forward[j].y >= 0 &&
                          forward[j].x <= frames[i].cols - 1 && forward[j].y <= frames[i].rows - 1;
      const cv::Point2f travel = forward[j] - corners[j];
      const double bound =
          std::max(options.max_forward_backward_px,
                   options.max_forward_backward_fraction * std::hypot(travel.x, travel.y));
      valid[i][j] = status_forward[j] && status_backward[j] && inside && d.dot(d) <= bound * bound;
      // A lost track keeps its neighbour's position as the next frame's guess.
      if (!valid[i][j]) forward[j] = positions[neighbour][j];
    }
    positions[i] = std::move(forward);
    ReportProgress(options.progress, "features", ++tracked_frames + 1, steps);
  }

  // Each frame's motion as the homography that fits KLT's matches: its
  // Jacobian at a corner is how that corner's patch turned and sheared.
  std::vector<std::optional<cv::Matx33d>> motion(n);
  if (options.gain_bias && options.predicted_shape)
    for (int i = 0; i < n; ++i)
      if (i != reference) motion[i] = FitFrameMotion(corners, positions[i], valid[i]);
  if (options.gain_bias && m > 0) {
    // Track by track, so that each reference patch is prepared once for all
    // of its frames; every match KLT kept, so that a frame that loses the
    // track does not hide the frames that keep it (FramesToLeaveOut).
    GainBiasAlignmentOptions alignment = options.alignment;
    alignment.window = options.klt_window;
    const GainBiasAligner aligner(ref, alignment);
    cv::parallel_for_(cv::Range(0, m), [&](const cv::Range& range) {
      GainBiasAligner::Patch patch;
      for (int j = range.start; j < range.end; ++j) {
        const bool prepared = aligner.Prepare(corners[j], &patch);
        for (int i = 0; i < n; ++i) {
          if (!valid[i][j] || i == reference) continue;
          const std::optional<std::array<float, 4>> shape =
              motion[i] ? std::optional(PatchShape(*motion[i], corners[j])) : std::nullopt;
          valid[i][j] =
              prepared && (shape && ShapeMovesTheWindow(*shape, options)
                               ? aligner.Align(patch, frames[i], shape->data(), &positions[i][j])
                               : aligner.Align(patch, frames[i], &positions[i][j]));
        }
        if (!prepared) valid[reference][j] = 0;
      }
    });
  }
  std::vector<GridedFeatureStats::LeftOut> left_out = FramesToLeaveOut(valid, reference, options);
  std::vector<int> kept_frames;
  for (int i = 0; i < n; ++i)
    if (std::none_of(left_out.begin(), left_out.end(),
                     [i](const GridedFeatureStats::LeftOut& l) { return l.frame == i; }))
      kept_frames.push_back(i);
  std::vector<int> kept;
  for (int j = 0; j < m; ++j)
    if (std::all_of(kept_frames.begin(), kept_frames.end(), [&](int i) { return valid[i][j]; }))
      kept.push_back(j);
  FeatureTracks tracks;
  tracks.reference = static_cast<int>(std::find(kept_frames.begin(), kept_frames.end(), reference) -
                                      kept_frames.begin());
  for (const int i : kept_frames) {
    Eigen::Matrix2Xd pixels(2, kept.size());
    for (size_t k = 0; k < kept.size(); ++k)
      pixels.col(k) << positions[i][kept[k]].x, positions[i][kept[k]].y;
    tracks.pixels.push_back(std::move(pixels));
  }
  if (stats) {
    stats->cells = ((ref.cols + cell - 1) / cell) * ((ref.rows + cell - 1) / cell);
    stats->corners = m;
    stats->tracks = static_cast<int>(kept.size());
    stats->reached.clear();
    for (int i = 0; i < n; ++i)
      stats->reached.push_back(static_cast<int>(std::count(valid[i].begin(), valid[i].end(), 1)));
    stats->kept_frames = kept_frames;
    stats->left_out = std::move(left_out);
  }
  return tracks;
}

}  // namespace dfsm
