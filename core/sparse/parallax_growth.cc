#include "core/sparse/parallax_growth.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>
#include <stdexcept>
#include <string>

#include "core/sparse/grided_features.h"

namespace dfsm {
namespace {

void Require(bool holds, const std::string& what) {
  if (!holds) throw std::invalid_argument(what);
}

// The q-quantile of `values` (not empty), by rank.
double Quantile(std::vector<double> values, double q) {
  const auto at = values.begin() + static_cast<std::ptrdiff_t>(q * (values.size() - 1) + 0.5);
  std::nth_element(values.begin(), at, values.end());
  return *at;
}

// One step of the tracks from `from` to `to`: KLT forward and back, a track
// that fails either way or does not come back ends (alive false).
void TrackStep(const cv::Mat& from, const cv::Mat& to, const ParallaxGrowthOptions& options,
               std::vector<cv::Point2f>* points, std::vector<char>* alive) {
  const cv::Size window(options.klt_window, options.klt_window);
  std::vector<cv::Point2f> forward, backward;
  std::vector<unsigned char> forward_ok, backward_ok;
  std::vector<float> error;
  cv::calcOpticalFlowPyrLK(from, to, *points, forward, forward_ok, error, window,
                           options.klt_levels);
  cv::calcOpticalFlowPyrLK(to, from, forward, backward, backward_ok, error, window,
                           options.klt_levels);
  for (size_t i = 0; i < points->size(); ++i) {
    const cv::Point2f back = backward[i] - (*points)[i];
    if (!forward_ok[i] || !backward_ok[i] ||
        std::hypot(back.x, back.y) > options.max_forward_backward_px)
      (*alive)[i] = 0;
    (*points)[i] = forward[i];
  }
}

// The image motion of a camera that only turns, read out row by row: the
// first frame's pixel moved by K R K^-1, K of focal length f about the image
// centre, R the turn from the row the point was read in the first frame to
// its row in this one. To first order in the small angles that turn is
// a + b s - c s0, s and s0 the rows' times from the middle row in frame
// heights: a the frame's turn, b its turn during one readout (a rolling
// shutter; 0 for a global one), c the first frame's. A turn moves every
// point alike whatever its depth; what it leaves is parallax.
struct TurnOnlyError {
  TurnOnlyError(cv::Point2f first, cv::Point2f seen, cv::Point2f centre)
      : x0(first.x - centre.x),
        y0(first.y - centre.y),
        u(seen.x - centre.x),
        v(seen.y - centre.y),
        s0(y0 / (2.0 * centre.y)),
        s(v / (2.0 * centre.y)) {}

  template <typename T>
  bool operator()(const T* const f, const T* const turn, const T* const readout_turn,
                  const T* const first_readout_turn, T* residual) const {
    T rotation[3];
    for (int i = 0; i < 3; ++i)
      rotation[i] = turn[i] + T(s) * readout_turn[i] - T(s0) * first_readout_turn[i];
    const T ray[3] = {T(x0) / f[0], T(y0) / f[0], T(1.0)};
    T turned[3];
    ceres::AngleAxisRotatePoint(rotation, ray, turned);
    residual[0] = f[0] * turned[0] / turned[2] - T(u);
    residual[1] = f[0] * turned[1] / turned[2] - T(v);
    return true;
  }

  double x0, y0, u, v, s0, s;
};

// The tracks of the first frame's corners: where each is in every frame
// (scaled pixels) and up to which frame it lives.
struct ScaledTracks {
  std::vector<std::vector<cv::Point2f>> points;  // [frame][track]
  std::vector<std::vector<char>> alive;          // [frame][track]
  int frames = 0;                                // frames with min_tracks alive
};

ScaledTracks TrackCorners(const std::vector<cv::Mat>& small, const std::vector<cv::Point2f>& first,
                          const ParallaxGrowthOptions& options) {
  ScaledTracks tracks;
  tracks.points.push_back(first);
  tracks.alive.emplace_back(first.size(), 1);
  tracks.frames = 1;
  for (size_t k = 1; k < small.size(); ++k) {
    std::vector<cv::Point2f> points = tracks.points.back();
    std::vector<char> alive = tracks.alive.back();
    TrackStep(small[k - 1], small[k], options, &points, &alive);
    if (std::count(alive.begin(), alive.end(), 1) < options.min_tracks) break;
    tracks.points.push_back(std::move(points));
    tracks.alive.push_back(std::move(alive));
    tracks.frames = static_cast<int>(k) + 1;
  }
  return tracks;
}

// The turn-only motion fitted to the tracks: one focal length and first
// frame's readout turn for the burst, a turn and a readout turn per frame.
struct TurnFit {
  double f = 0.0;  // scaled pixels
  std::array<double, 3> first_readout_turn = {0.0, 0.0, 0.0};
  std::vector<std::array<double, 3>> turn, readout_turn;  // [frame]; [0] none

  // Where the turn alone moves the first frame's `first` in frame k,
  // against `seen` there (scaled pixels).
  double Beyond(int k, cv::Point2f first, cv::Point2f seen, cv::Point2f centre) const {
    double residual[2];
    TurnOnlyError(first, seen, centre)(&f, turn[k].data(), readout_turn[k].data(),
                                       first_readout_turn.data(), residual);
    return std::hypot(residual[0], residual[1]);
  }
};

TurnFit FitTurns(const ScaledTracks& tracks, cv::Size size, const ParallaxGrowthOptions& options) {
  const cv::Point2f centre(0.5f * size.width, 0.5f * size.height);
  const double longer = std::max(size.width, size.height);
  TurnFit fit;
  fit.f = longer;  // 53 deg across the longer side; the fit moves it
  fit.turn.assign(tracks.frames, {0.0, 0.0, 0.0});
  fit.readout_turn.assign(tracks.frames, {0.0, 0.0, 0.0});
  ceres::Problem problem;
  for (int k = 1; k < tracks.frames; ++k) {
    for (size_t i = 0; i < tracks.points[0].size(); ++i) {
      if (!tracks.alive[k][i]) continue;
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<TurnOnlyError, 2, 1, 3, 3, 3>(
              new TurnOnlyError(tracks.points[0][i], tracks.points[k][i], centre)),
          new ceres::CauchyLoss(options.loss_scale_px), &fit.f, fit.turn[k].data(),
          fit.readout_turn[k].data(), fit.first_readout_turn.data());
    }
  }
  if (problem.NumResidualBlocks() == 0) return fit;
  problem.SetParameterLowerBound(&fit.f, 0, 0.3 * longer);
  problem.SetParameterUpperBound(&fit.f, 0, 3.0 * longer);
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::DENSE_QR;
  solver.max_num_iterations = 50;
  solver.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  return fit;
}

}  // namespace

void ParallaxGrowthOptions::Check() const {
  Require(max_side >= 64, "parallax growth: max_side must be at least 64");
  Require(corners >= 8, "parallax growth: corners must be at least 8");
  Require(min_corner_quality > 0.0 && min_corner_quality < 1.0,
          "parallax growth: min_corner_quality must be in (0, 1)");
  Require(klt_window >= 3 && klt_window % 2 == 1, "parallax growth: klt_window must be odd, >= 3");
  Require(klt_levels >= 0 && klt_levels <= 8, "parallax growth: klt_levels must be in [0, 8]");
  Require(max_forward_backward_px > 0.0, "parallax growth: max_forward_backward_px must be > 0");
  Require(loss_scale_px > 0.0, "parallax growth: loss_scale_px must be > 0");
  Require(min_tracks >= 4, "parallax growth: min_tracks must be at least 4");
}

// The pipeline's tracker (grided corners, KLT from the first frame to each,
// realigned with gain and bias) at full resolution.
ScaledTracks PipelineTracks(const std::vector<cv::Mat>& gray, int min_tracks) {
  GridedFeatureStats stats;
  const FeatureTracks tracks = TrackGridedFeatures(gray, 0, GridedFeatureOptions(), &stats);
  ScaledTracks scaled;
  if (tracks.num_tracks() < min_tracks) return scaled;
  for (int k = 0; k < tracks.num_frames(); ++k) {
    if (stats.kept_frames[k] != k) break;
    std::vector<cv::Point2f> points;
    for (int i = 0; i < tracks.num_tracks(); ++i)
      points.emplace_back(tracks.pixels[k](0, i), tracks.pixels[k](1, i));
    scaled.points.push_back(points);
    scaled.alive.emplace_back(points.size(), 1);
    scaled.frames = k + 1;
  }
  return scaled;
}

ParallaxGrowth MeasureParallaxGrowth(const std::vector<cv::Mat>& gray,
                                     const ParallaxGrowthOptions& options) {
  options.Check();
  if (options.pipeline_tracker) {
    ParallaxGrowth growth;
    growth.parallax_px.assign(gray.size(), 0.0);
    growth.parallax_p90_px.assign(gray.size(), 0.0);
    const ScaledTracks tracks = PipelineTracks(gray, options.min_tracks);
    if (tracks.frames == 0) return growth;
    growth.tracks = static_cast<int>(tracks.points[0].size());
    const TurnFit fit = FitTurns(tracks, gray[0].size(), options);
    growth.focal_px = fit.f;
    growth.tracked_frames = tracks.frames;
    const cv::Point2f centre(0.5f * gray[0].cols, 0.5f * gray[0].rows);
    for (int k = 1; k < tracks.frames; ++k) {
      std::vector<double> beyond;
      for (size_t i = 0; i < tracks.points[0].size(); ++i)
        beyond.push_back(fit.Beyond(k, tracks.points[0][i], tracks.points[k][i], centre));
      growth.parallax_px[k] = std::max(growth.parallax_px[k - 1], Quantile(beyond, 0.5));
      growth.parallax_p90_px[k] = std::max(growth.parallax_p90_px[k - 1], Quantile(beyond, 0.9));
    }
    return growth;
  }
  ParallaxGrowth growth;
  if (gray.empty()) return growth;
  const int longer = std::max(gray[0].cols, gray[0].rows);
  const double scale = std::min(1.0, static_cast<double>(options.max_side) / longer);
  std::vector<cv::Mat> small(gray.size());
  for (size_t k = 0; k < gray.size(); ++k) {
    if (gray[k].type() != CV_8UC1 || gray[k].size() != gray[0].size())
      throw std::invalid_argument("parallax growth: frames must be gray8 of one size");
    if (scale < 1.0)
      cv::resize(gray[k], small[k], cv::Size(), scale, scale, cv::INTER_AREA);
    else
      small[k] = gray[k];
  }
  std::vector<cv::Point2f> first;
  const double spacing = std::sqrt(static_cast<double>(small[0].total()) / options.corners) / 2;
  cv::goodFeaturesToTrack(small[0], first, options.corners, options.min_corner_quality, spacing);
  growth.tracks = static_cast<int>(first.size());
  growth.parallax_px.assign(gray.size(), 0.0);
  growth.parallax_p90_px.assign(gray.size(), 0.0);
  if (growth.tracks < options.min_tracks) return growth;
  const ScaledTracks tracks = TrackCorners(small, first, options);
  const TurnFit fit = FitTurns(tracks, small[0].size(), options);
  growth.focal_px = fit.f / scale;
  growth.tracked_frames = tracks.frames;
  const cv::Point2f centre(0.5f * small[0].cols, 0.5f * small[0].rows);
  for (int k = 1; k < tracks.frames; ++k) {
    std::vector<double> beyond;
    for (size_t i = 0; i < first.size(); ++i)
      if (tracks.alive[k][i])
        beyond.push_back(fit.Beyond(k, first[i], tracks.points[k][i], centre));
    growth.parallax_px[k] = std::max(growth.parallax_px[k - 1], Quantile(beyond, 0.5) / scale);
    growth.parallax_p90_px[k] =
        std::max(growth.parallax_p90_px[k - 1], Quantile(beyond, 0.9) / scale);
  }
  return growth;
}

void BurstLengthOptions::Check() const {
  Require(min_frames >= 3, "burst length: min_frames must be at least 3");
  Require(target_parallax_px > 0.0, "burst length: target_parallax_px must be > 0");
  Require(min_parallax_px >= 0.0 && min_parallax_px <= target_parallax_px,
          "burst length: min_parallax_px must be in [0, target_parallax_px]");
}

const char* BurstLengthReasonName(BurstLengthReason reason) {
  switch (reason) {
    case BurstLengthReason::kParallaxReached:
      return "parallax reached";
    case BurstLengthReason::kMaximumFrames:
      return "maximum frames";
    case BurstLengthReason::kTracksLost:
      return "tracks lost";
    case BurstLengthReason::kTooStill:
      return "too still";
  }
  return "unknown";
}

BurstLength ChooseBurstLength(const ParallaxGrowth& growth, const BurstLengthOptions& options) {
  options.Check();
  const int all = static_cast<int>(growth.parallax_px.size());
  const int first_measured = std::min(options.min_frames, all);
  BurstLength length;
  for (int frames = first_measured; frames <= growth.tracked_frames; ++frames) {
    if (growth.parallax_px[frames - 1] >= options.target_parallax_px) {
      length.frames = frames;
      length.parallax_px = growth.parallax_px[frames - 1];
      length.reason = BurstLengthReason::kParallaxReached;
      return length;
    }
  }
  const int measured = std::max(growth.tracked_frames, 1);
  length.parallax_px = growth.parallax_px.empty() ? 0.0 : growth.parallax_px[measured - 1];
  if (growth.tracked_frames < all) {
    length.frames = std::max(growth.tracked_frames, first_measured);
    length.reason = BurstLengthReason::kTracksLost;
  } else {
    length.frames = all;
    length.reason = length.parallax_px < options.min_parallax_px
                        ? BurstLengthReason::kTooStill
                        : BurstLengthReason::kMaximumFrames;
  }
  return length;
}

}  // namespace dfsm
