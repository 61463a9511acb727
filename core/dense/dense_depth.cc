#include "core/dense/dense_depth.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/camera/rolling_shutter.h"
#include "core/dense/bilinear_upsample.h"
#include "core/dense/dense_frames.h"
#include "core/dense/depth_discontinuity.h"
#include "core/dense/guided_filter.h"
#include "core/dense/high_pass.h"
#include "core/dense/inverse_depth_lattice.h"
#include "core/dense/plane_selection.h"
#include "core/dense/plane_sweep.h"
#include "core/dense/radial_inverse.h"
#include "core/dense/semi_global.h"
#include "core/dense/sweep_level.h"
#include "core/dense/weak_texture.h"
#include "core/io/stage_timer.h"
#include "core/parallel/parallel_for.h"

namespace dfsm {
namespace {

// The coarse level's width the default scale aims at: the scale is the
// integer in [2, 4] nearest width / kCoarseLevelWidth (1080p: 4, 480
// columns; 720p: 3, 427; 640x480: 2, 320). A coarse pixel seeds the
// full-resolution window and gives it its confidence, so a level too coarse
// for the image blurs both across depth edges: at 1280x720 the rule that preceded this one (width /
// 320, 4 at 720p: 320 columns) left the depth sweep's 720p bursts 3.27 %
// AbsRel (filled 4.58 %) against 3.12 % (4.12 %) at 3 (docs/experiments/230-coarse-level-width.md).
// At 1080p, 3 would gain as much but double the coarse sweep, past the time budget.
constexpr double kCoarseLevelWidth = 480.0;

// A coarse level narrower than this seeds the full-resolution window less
// precisely (each coarse pixel spans more of the scene), and the default
// window reaches one plane further each way there: bursts under 800 px wide
// (640x480: 320 columns). On TUM fr1/xyz (640x480, real frames) 7 planes
// left a window-edge hole wherever the seed missed by more than +-1 pixel of
// parallax: 9 planes measure 5-12 points more of the pixels
// (window 0-9: 37.9 -> 43.9 %) at the same AbsRel (median 4.1 %); at 720p and
// 1080p (427 and 480 columns) 9 planes were no better on generated bursts and
// cost the 1080p budget a quarter of the fine sweep
// (docs/experiments/231-full-resolution-window.md).
constexpr int kNarrowCoarseLevelWidth = 400;

void Require(bool condition, const std::string& message) {
  if (!condition) throw std::invalid_argument("dense: " + message);
}

void ValidateInputs(const Burst& burst, const CameraModel& camera, const std::vector<Pose>& poses,
                    const DenseOptions& options) {
  Require(burst.size() >= 2,
          "need the reference and at least one other frame, got " + std::to_string(burst.size()));
  Require(burst.reference() >= 0 && burst.reference() < burst.size(),
          "reference index " + std::to_string(burst.reference()) + " outside the " +
              std::to_string(burst.size()) + " frames");
  Require(static_cast<int>(poses.size()) == burst.size(),
          std::to_string(poses.size()) + " poses for " + std::to_string(burst.size()) + " frames");
  CheckFrameTimes(options.frame_times, burst.size());
  CheckAngularVelocities(options.angular_velocities, burst.size());
  Require(camera.width == burst.width() && camera.height == burst.height(),
          "camera is " + std::to_string(camera.width) + "x" + std::to_string(camera.height) +
              " but the burst is " + std::to_string(burst.width()) + "x" +
              std::to_string(burst.height()));
  for (int i = 0; i < burst.size(); ++i) {
    const cv::Mat& frame = burst.gray[i];
    Require(frame.type() == CV_8UC1 && frame.cols == burst.width() && frame.rows == burst.height(),
            "frame " + std::to_string(i) + " is not 8-bit gray of the burst's size");
    Require(poses[i].R.allFinite() && poses[i].T.allFinite(),
            "pose " + std::to_string(i) + " is not finite");
  }
  // The fill reads the reference in colour where it is 8-bit BGR (and the
  // gray frame otherwise).
  const cv::Mat& color = burst.reference_color;
  Require(color.empty() || (color.cols == burst.width() && color.rows == burst.height()),
          "reference_color is not of the burst's size");
  options.Check();
  const int scale = CoarseScale(burst.width(), options);
  Require(burst.width() / scale >= 8 && burst.height() / scale >= 8,
          "image " + std::to_string(burst.width()) + "x" + std::to_string(burst.height()) +
              " too small for coarse_scale " + std::to_string(scale));
}

// Coarse planes are spaced this far apart in coarse pixels of parallax, fine
// windows this far in full-resolution pixels (when the options leave them to
// the data): well below the matching precision of either level, so the
// parabola through three neighbours still resolves the minimum; the 1080p
// phone bursts' seeds, and so the filled map, want the coarse level this
// fine (docs/experiments/241-coarse-plane-spacing.md).
constexpr double kCoarsePlaneParallax = 0.15;
constexpr double kFinePlaneParallax = 0.35;
// Level pixels of parallax between the planes a sweep projects exactly; the
// samples of the planes between move on a straight line to within ~0.01
// pixel over such a span (the fine window spans about as much: 6 x 0.35).
constexpr double kProjectedSpan = 2.0;

// Where more than `share` of the confident coarse pixels (plane >= 0,
// confidence > 0) won the nearest plane of a coarse lattice of
// `coarse_planes`, extends `lattice` toward the camera by its width and
// returns true. Only toward the camera: the far end is also where a wrong
// geometry spreads a map, and extending it there made such bursts worse
// (docs/experiments/228-depth-sweep.md); the depth check warns of either end.
bool ExtendTowardTheCamera(const PlaneSelection& coarse, int coarse_planes, double share,
                           InverseDepthLattice* lattice) {
  if (!(share > 0.0) || coarse_planes < 2) return false;
  long confident = 0, nearest = 0;
  const float last = static_cast<float>(coarse_planes - 1);
  for (int y = 0; y < coarse.plane.rows; ++y) {
    const float* p = coarse.plane.ptr<float>(y);
    const float* c = coarse.confidence.ptr<float>(y);
    for (int x = 0; x < coarse.plane.cols; ++x) {
      if (p[x] < 0.0f || !(c[x] > 0.0f)) continue;
      ++confident;
      nearest += p[x] > last - 0.5f;
    }
  }
  if (confident == 0 || nearest <= share * confident) return false;
  lattice->max_inverse_depth += lattice->max_inverse_depth - lattice->min_inverse_depth;
  return true;
}

// Largest image motion (pixels) per unit of inverse depth over the frames: a
// point at inverse depth w moves by about f |T_xy + x T_z| w.
double MaxParallaxPerInverseDepth(const CameraModel& camera, const std::vector<Pose>& poses) {
  const double corner = std::hypot(camera.width, camera.height) / (2.0 * camera.f);
  double largest = 0.0;
  for (const Pose& pose : poses)
    largest =
        std::max(largest, camera.f * (pose.T.head<2>().norm() + corner * std::abs(pose.T.z())));
  return std::max(largest, 1e-12);
}

// Throws, as ValidateInputs does, unless `prepared` was made of this burst
// with these settings: the sweeps would compare other frames than the
// options ask for.
void ValidatePreparedFrames(const DenseFrames& prepared, const Burst& burst,
                            const DenseFramesSettings& settings) {
  const cv::Size size(burst.width(), burst.height());
  // The coarse level's own frames: of its size where the settings call for
  // them, none otherwise.
  const cv::Size coarse_size(burst.width() / settings.coarse_scale,
                             burst.height() / settings.coarse_scale);
  const bool separate = settings.SeparateCoarseFrames();
  bool coarse_frames_fit =
      separate ? prepared.coarse_reference.size() == coarse_size &&
                     prepared.coarse_others.size() == prepared.others.size()
               : prepared.coarse_reference.empty() && prepared.coarse_others.empty();
  for (const cv::Mat& frame : prepared.coarse_others)
    coarse_frames_fit = coarse_frames_fit && frame.size() == coarse_size;
  Require(prepared.settings == settings && prepared.reference == burst.reference() &&
              static_cast<int>(prepared.others.size()) == burst.size() - 1 &&
              prepared.reference_filtered.size() == size &&
              prepared.reference_gray.size() == size && coarse_frames_fit,
          "the prepared frames were made from another burst or with other high_pass_sigma_px, "
          "fine_high_pass_ratio, prefilter_sigma or coarse_scale");
}

// The high-passed frames the sweeps compare, each held on its own so that
// it can be released as soon as nothing reads it again.
struct SweptFrames {
  cv::Mat high_passed_reference;  // 8-bit: the refinement's guide, the fill's without colour
  cv::Mat reference;
  std::vector<cv::Mat> frames;
  // The coarse level's own frames where it has them (DenseFramesSettings).
  cv::Mat coarse_reference;
  std::vector<cv::Mat> coarse_frames;
};

// The frames of `prepared`, taken over (it is left without them), or made
// here where it is empty.
SweptFrames TakeSweptFrames(const Burst& burst, const DenseFramesSettings& settings,
                            std::optional<DenseFrames>* prepared) {
  DenseFrames prepared_here;
  if (!*prepared) prepared_here = PrepareDenseFrames(burst, settings);
  DenseFrames& made = *prepared ? **prepared : prepared_here;
  SweptFrames swept;
  swept.high_passed_reference = made.reference_gray;
  swept.reference = std::move(made.reference_filtered);
  swept.frames = std::move(made.others);
  swept.coarse_reference = std::move(made.coarse_reference);
  swept.coarse_frames = std::move(made.coarse_others);
  made = DenseFrames();
  return swept;
}

// A level's frames go on the 2x grid while the level has at most
// oversample_max_pixels pixels (every level below 1080p, the coarse one at 1080p).
int OversampleFactor(const Burst& burst, const DenseOptions& options, int level_scale) {
  const double pixels =
      static_cast<double>(burst.width() / level_scale) * (burst.height() / level_scale);
  return pixels <= options.oversample_max_pixels ? 2 : 1;
}

// The coarse level, from its own frames where it has them (which it then
// gives up: nothing else reads them), from the full-resolution ones
// otherwise.
SweepLevel MakeCoarseLevel(const Burst& burst, const CameraModel& camera,
                           const RadialInverse& radial, const SweepPoses& sweep_poses,
                           const DenseOptions& options, int scale, SweptFrames* swept) {
  const bool own_coarse_frames = !swept->coarse_frames.empty();
  SweepLevel coarse =
      MakeSweepLevel(own_coarse_frames ? swept->coarse_reference : swept->reference,
                     own_coarse_frames ? swept->coarse_frames : swept->frames, sweep_poses, camera,
                     radial, scale, OversampleFactor(burst, options, scale));
  swept->coarse_reference.release();
  swept->coarse_frames.clear();
  return coarse;
}

// What the lattice's planes mean in the images, and what that makes of the
// coarse lattice and of the full-resolution window around each coarse seed.
struct SweepGeometry {
  // Full-resolution pixels of parallax between neighbouring lattice planes.
  double plane_parallax = 0.0;
  // Lattice planes per coarse plane.
  double lattice_ratio = 1.0;
  InverseDepthLattice coarse_lattice;
  // PhotoCostOptions::projected_every of the coarse sweep.
  int projected_every = 1;
  // The window: `window` planes, `stride` lattice planes apart, reaching
  // `reach` lattice planes each way.
  int stride = 1, window = 1, reach = 0;
};

// The geometry of one coarse pass over `lattice`: planes spaced by their
// parallax in the frame that moves most, so that a plane means the same in
// the images whatever the burst's motion and range.
SweepGeometry PlanSweep(const InverseDepthLattice& lattice, const CameraModel& camera,
                        const std::vector<Pose>& other_poses, int scale, int width,
                        const DenseOptions& options) {
  SweepGeometry geometry;
  // Parallax (full-resolution pixels) between neighbouring lattice planes in
  // the frame that moves most: what "a plane" means in the images.
  geometry.plane_parallax = MaxParallaxPerInverseDepth(camera, other_poses) * lattice.step();
  const double plane_parallax = geometry.plane_parallax;
  InverseDepthLattice& coarse_lattice = geometry.coarse_lattice;
  coarse_lattice = lattice;
  if (scale > 1) {
    coarse_lattice.planes =
        options.coarse_planes > 0
            ? options.coarse_planes
            : std::clamp(static_cast<int>(std::ceil(plane_parallax * (lattice.planes - 1) /
                                                    (scale * kCoarsePlaneParallax))) +
                             1,
                         std::min(16, lattice.planes), lattice.planes);
  }
  // Coarse pixels of parallax between neighbouring coarse planes; exact
  // projections kProjectedSpan apart, the planes between interpolated.
  const double coarse_plane_parallax =
      plane_parallax * (lattice.planes - 1) / std::max(1, coarse_lattice.planes - 1) / scale;
  geometry.projected_every =
      std::max(1, static_cast<int>(std::floor(kProjectedSpan / coarse_plane_parallax)));
  // The full-resolution window around each coarse seed.
  geometry.stride =
      options.refine_stride > 0
          ? options.refine_stride
          : std::max(1, static_cast<int>(std::lround(kFinePlaneParallax / plane_parallax)));
  geometry.window =
      std::min(2 * RefineRadius(width, options) + 1, (lattice.planes - 1) / geometry.stride + 1);
  geometry.reach = (geometry.window - 1) / 2 * geometry.stride;
  geometry.lattice_ratio = static_cast<double>(lattice.planes - 1) / (coarse_lattice.planes - 1);
  return geometry;
}

// The winners of one coarse pass. Regularized (semi_global.h), a winner is
// measured only as far as the pixel's own curve supports it: its confidence
// is that curve's, and where no depth explains the frames (max_cost_ratio)
// it is an outlier, marked in `outliers`. Otherwise each pixel's own winner.
PlaneSelection SelectCoarsePlanes(const SweepLevel& coarse, const SweepGeometry& geometry,
                                  int scale, const PhotoCostOptions& cost,
                                  const DenseOptions& options, cv::Mat* outliers,
                                  double* outlier_fraction) {
  if (!options.regularize) return SweepAllPlanes(coarse, geometry.coarse_lattice, cost);
  const std::vector<cv::Mat> costs = SweepAllPlaneCosts(coarse, geometry.coarse_lattice, cost);
  PlaneSelection coarse_selection =
      SelectSemiGlobal(costs, coarse.reference, options.truncation, options.semi_global);
  // Measured where the pixel's own curve has its minimum within the fine
  // window's reach of the regularized seed (scale 1: no window, the same plane).
  const int coarse_reach =
      scale > 1 ? static_cast<int>(geometry.reach / geometry.lattice_ratio) : 0;
  cv::Mat valley_cost;
  coarse_selection.confidence =
      ConfidenceOfPlanes(costs, coarse_selection.plane, coarse_reach, &valley_cost);
  if (options.max_cost_ratio > 0.0)
    *outlier_fraction = static_cast<double>(RejectCostOutliers(
                            valley_cost, coarse.reference, options.coarse_window_radius,
                            options.max_cost_ratio, &coarse_selection.confidence, outliers)) /
                        valley_cost.total();
  return coarse_selection;
}

// The coarse sweep's winners, their photo-consistency outliers (255; empty
// without any) and the geometry of the pass that found them.
struct CoarseSweep {
  PlaneSelection selection;
  cv::Mat outliers;
  SweepGeometry geometry;
};

// Sweeps the coarse level over `lattice`, the tracks' range widened by a
// margin. A surface nearer than every inlier track (no track on it:
// rejected with the lens model's error in a corner, or none found) takes
// the nearest plane of the coarse sweep; where more than
// options.range_extension_share of the confident coarse pixels do, the
// range is extended toward the camera by its own width and the coarse level
// swept again, once (docs/experiments/228-depth-sweep.md).
CoarseSweep SweepCoarseLevel(const SweepLevel& coarse, const CameraModel& camera,
                             const std::vector<Pose>& other_poses, int scale, int width,
                             const DenseOptions& options, InverseDepthLattice* lattice,
                             PhotoCostOptions* cost, DenseDepth* result) {
  result->coarse_scale = scale;
  CoarseSweep sweep;
  for (int pass = 0;; ++pass) {
    sweep.geometry = PlanSweep(*lattice, camera, other_poses, scale, width, options);
    result->coarse_planes = sweep.geometry.coarse_lattice.planes;
    cost->projected_every = sweep.geometry.projected_every;
    sweep.outliers.release();
    sweep.selection = SelectCoarsePlanes(coarse, sweep.geometry, scale, *cost, options,
                                         &sweep.outliers, &result->outlier_fraction);
    if (pass > 0 || !ExtendTowardTheCamera(sweep.selection, sweep.geometry.coarse_lattice.planes,
                                           options.range_extension_share, lattice))
      break;
    result->range_extended = true;
  }
  result->min_inverse_depth = lattice->min_inverse_depth;
  result->max_inverse_depth = lattice->max_inverse_depth;
  result->planes = lattice->planes;
  return sweep;
}

// Coarse plane indices onto the full lattice, "none" kept at -1.
void CoarsePlanesOntoLattice(const SweepGeometry& geometry, const InverseDepthLattice& lattice,
                             PlaneSelection* coarse_selection) {
  if (geometry.coarse_lattice.planes == lattice.planes) return;
  const double lattice_ratio = geometry.lattice_ratio;
  cv::Mat& p = coarse_selection->plane;
  p.setTo(cv::Scalar(-1.0f / lattice_ratio), p < 0.0f);  // keeps "none" at -1
  p.convertTo(p, CV_32F, lattice_ratio);
}

// What the coarse winners give the full-resolution window at each pixel.
struct FineSeeds {
  cv::Mat first;              // CV_32SC1, the window's first lattice plane
  cv::Mat coarse_confidence;  // CV_32FC1, 0 wherever a coarse outlier is nearest
  cv::Mat seed;               // CV_32FC1, the upsampled coarse winner; empty without a prior
};

// The coarse winners and confidence upsampled to `full`, evaluated on the
// fly rather than materialized (bilinear_upsample.h).
FineSeeds UpsampleCoarseSeeds(const CoarseSweep& coarse_sweep, const InverseDepthLattice& lattice,
                              const cv::Size& full, int scale, const DenseOptions& options) {
  const PlaneSelection& coarse_selection = coarse_sweep.selection;
  const cv::Mat& outliers = coarse_sweep.outliers;
  const int stride = coarse_sweep.geometry.stride;
  const int window = coarse_sweep.geometry.window;
  const int reach = coarse_sweep.geometry.reach;
  // A 3x3 median drops isolated coarse outliers before they seed the window.
  cv::Mat coarse_plane;
  cv::medianBlur(coarse_selection.plane, coarse_plane, 3);
  // Level pixel x sits at captured scale * x + (scale - 1) / 2, which is
  // exactly the pixel-centre alignment of cv::resize; rows and columns lost
  // to the integer downsampling repeat their neighbours.
  const UpsampleAxis rows(coarse_plane.rows, coarse_plane.rows * scale, full.height);
  const UpsampleAxis columns(coarse_plane.cols, coarse_plane.cols * scale, full.width);
  cv::Mat first(full, CV_32SC1), coarse_confidence(full, CV_32FC1);
  cv::Mat seed = options.seed_prior > 0.0 ? cv::Mat(full, CV_32FC1) : cv::Mat();
  ParallelRows(full.height, [&](int y) {
    const int r0 = rows.lower[y], r1 = r0 + rows.step[y];
    const float ty = rows.t[y];
    const float* p0 = coarse_plane.ptr<float>(r0);
    const float* p1 = coarse_plane.ptr<float>(r1);
    const float* c0 = coarse_selection.confidence.ptr<float>(r0);
    const float* c1 = coarse_selection.confidence.ptr<float>(r1);
    int* f = first.ptr<int>(y);
    float* s = seed.empty() ? nullptr : seed.ptr<float>(y);
    float* c = coarse_confidence.ptr<float>(y);
    // An outlier's zero would only dim its neighbours' confidence when
    // interpolated: every full-resolution pixel nearest to one is left out.
    const uchar* outlier = outliers.empty() ? nullptr : outliers.ptr<uchar>(rows.Nearest(y));
    for (int x = 0; x < full.width; ++x) {
      const float centre = Upsampled(p0, p1, ty, columns, x);
      if (s) s[x] = centre;
      f[x] = std::clamp(static_cast<int>(std::lround(centre)) - reach, 0,
                        lattice.planes - 1 - (window - 1) * stride);
      c[x] = outlier && outlier[columns.Nearest(x)] ? 0.0f : Upsampled(c0, c1, ty, columns, x);
    }
  });
  FineSeeds seeds;
  seeds.first = first;
  seeds.coarse_confidence = coarse_confidence;
  seeds.seed = seed;
  return seeds;
}

// Sweeps the window of planes around each seed at full resolution: wider
// aggregation windows where the texture is weak, the winners drawn towards
// the seed (SeedPrior). `cost` keeps the seed and the weak-texture mask.
PlaneSelection SweepFineWindow(const SweepLevel& fine, const InverseDepthLattice& lattice,
                               const FineSeeds& seeds, const SweepGeometry& geometry,
                               const DenseOptions& options, PhotoCostOptions* cost) {
  cost->window_radius = options.fine_window_radius;
  cost->shiftable_radius = options.fine_shiftable_radius;
  if (options.weak_texture_window_radius > options.fine_window_radius) {
    cost->wide_window_radius = options.weak_texture_window_radius;
    cost->wide_window_mask =
        WeakTextureMask(fine.reference, cost->wide_window_radius, options.weak_texture_gradient);
  }
  // seed_prior is per squared pixel of parallax; the selection's weight per
  // squared slice, `stride` lattice planes.
  cost->seed_prior.seed = seeds.seed;
  cost->seed_prior.weight = static_cast<float>(
      options.seed_prior * std::pow(geometry.stride * geometry.plane_parallax, 2));
  return SweepPlaneWindow(fine, lattice, seeds.first, geometry.window, geometry.stride, *cost);
}

// A winner on the window's edge means the coarse seed was off by more than
// the window: the true minimum lies outside what was searched, so its
// `confidence` goes to 0 (unless that edge is the lattice's own end), as
// does a pixel's without a winner.
void ClearConfidenceOffTheWindow(const PlaneSelection& fine_selection,
                                 const InverseDepthLattice& lattice, int stride,
                                 const cv::Size& full, cv::Mat* confidence) {
  const cv::Mat& plane = fine_selection.plane;
  ParallelRows(full.height, [&](int y) {
    const uchar* edge = fine_selection.at_edge.ptr<uchar>(y);
    const float* p = plane.ptr<float>(y);
    float* c = confidence->ptr<float>(y);
    for (int x = 0; x < full.width; ++x) {
      const bool lattice_end = p[x] < 0.5f * stride || p[x] > lattice.planes - 1 - 0.5f * stride;
      if (p[x] < 0.0f || (edge[x] && !lattice_end)) c[x] = 0.0f;
    }
  });
}

// Each pixel's weight in the refinement: its confidence where its winner
// counts as measured (options.min_confidence), 0 elsewhere.
cv::Mat MeasuredWeight(const cv::Mat& plane, const cv::Mat& confidence,
                       const DenseOptions& options) {
  const float min_confidence = static_cast<float>(options.min_confidence);
  cv::Mat weight(plane.size(), CV_32FC1);
  ParallelRows(plane.rows, [&](int y) {
    const float* p = plane.ptr<float>(y);
    const float* c = confidence.ptr<float>(y);
    float* wt = weight.ptr<float>(y);
    for (int x = 0; x < plane.cols; ++x)
      wt[x] = (p[x] >= 0.0f && c[x] >= min_confidence) ? c[x] : 0.0f;
  });
  return weight;
}

// The edge-aware refinement of the winners in `plane` (a guided filter on
// the reference), kept off depth edges, and `weight` taken from the pixels
// along a break between surfaces.
void RefinePlanes(const cv::Mat& high_passed_reference, const InverseDepthLattice& lattice,
                  double plane_parallax, const DenseOptions& options, cv::Mat* plane,
                  cv::Mat* weight) {
  // A break between surfaces, in planes (depth_discontinuity.h).
  SpanBound breaks;
  breaks.max_span = static_cast<float>(options.discontinuity_parallax / plane_parallax);
  breaks.min_relative_span = static_cast<float>(options.discontinuity_relative);
  breaks.zero_plane = static_cast<float>(-lattice.min_inverse_depth / lattice.step());
  // The reference on [0, 1]: the guide of the refinement.
  cv::Mat guide;
  if (options.guided_radius > 0) high_passed_reference.convertTo(guide, CV_32F, 1.0 / 255.0);
  // The filter returns a new image, so the raw winners stay as they are.
  const cv::Mat raw_plane = *plane;
  if (options.guided_radius > 0) {
    *plane = WeightedGuidedFilter(guide, raw_plane, *weight, options.guided_radius,
                                  static_cast<float>(options.guided_eps), nullptr,
                                  plane->cols > 1000 ? options.guided_subsample : 1);
    if (options.edge_guard_parallax > 0.0)
      KeepEdgesOfRawWinners(raw_plane, *weight,
                            static_cast<float>(options.edge_guard_parallax / plane_parallax),
                            options.discontinuity_parallax > 0.0
                                ? options.guided_radius + options.discontinuity_radius
                                : 0,
                            breaks, *plane);
  }
  guide.release();
  if (options.discontinuity_parallax > 0.0) {
    // Breaks among the raw winners and among the refined ones, both found
    // among the same measured pixels.
    cv::Mat raw_weight;
    if (options.guided_radius > 0 && options.raw_discontinuity_radius > 0) {
      raw_weight = weight->clone();
      InvalidateAlongDiscontinuities(raw_plane, options.raw_discontinuity_radius, breaks,
                                     raw_weight);
    }
    InvalidateAlongDiscontinuities(*plane, options.discontinuity_radius, breaks, *weight);
    if (!raw_weight.empty()) weight->setTo(0.0f, raw_weight <= 0.0f);
  }
}

// The depth of every pixel with a weight, and the share of such pixels. A
// pixel left without depth (discontinuity bands, depths behind the camera)
// has no confidence either, so that measured is exactly confidence >=
// min_confidence: what result.json tells a user.
void SetMeasuredDepth(const cv::Mat& plane, const cv::Mat& weight, const cv::Mat& confidence,
                      const InverseDepthLattice& lattice, const DenseOptions& options,
                      DenseDepth* result) {
  result->depth = cv::Mat::zeros(plane.size(), CV_32FC1);
  result->confidence = confidence;
  ParallelRows(plane.rows, [&](int y) {
    const float* p = plane.ptr<float>(y);
    const float* wt = weight.ptr<float>(y);
    float* d = result->depth.ptr<float>(y);
    for (int x = 0; x < plane.cols; ++x) {
      if (wt[x] <= 0.0f) continue;
      const double w = lattice.At(p[x]);
      if (w > 0.0) d[x] = static_cast<float>(1.0 / w);
    }
  });
  result->confidence.setTo(0.0f, result->depth <= 0.0f);
  result->min_confidence = options.min_confidence;
  result->valid_fraction = DepthFraction(result->depth);
}

// result->depth_filled: the depth with its holes filled from the measured
// pixels (depth_completion.h); left empty where there is nothing to fill
// from. Measured pixels weigh in with their confidence, which is 0 at every
// pixel without a depth (the discontinuity bands too are holes). The fill
// follows the reference's colour edges where it has colour (as captured:
// the high-pass is for matching, an edge is an edge).
void FillDepthHoles(const cv::Mat& plane, const Burst& burst, const cv::Mat& high_passed_reference,
                    const InverseDepthLattice& lattice, const DenseOptions& options,
                    DenseDepth* result) {
  const cv::Mat& color = burst.reference_color;
  const bool has_color = color.type() == CV_8UC3;  // its size is checked up front
  const cv::Mat filled = FillHoles(plane, result->confidence,
                                   has_color ? color : high_passed_reference, options.completion);
  if (filled.empty()) return;
  result->depth_filled = result->depth.clone();
  const float last = static_cast<float>(lattice.planes - 1);
  ParallelRows(filled.rows, [&](int y) {
    const float* p = filled.ptr<float>(y);
    float* d = result->depth_filled.ptr<float>(y);
    for (int x = 0; x < filled.cols; ++x) {
      if (d[x] > 0.0f) continue;
      const double w = lattice.At(std::clamp(p[x], 0.0f, last));
      if (w > 0.0) d[x] = static_cast<float>(1.0 / w);
    }
  });
}

}  // namespace

void DenseOptions::Check() const {
  Require(planes >= kMinPlanes && planes <= kMaxPlanes,
          "planes must be " + std::to_string(kMinPlanes) + " to " + std::to_string(kMaxPlanes));
  Require(coarse_scale >= 0, "coarse_scale must be >= 0 (0: from the image width)");
  Require(coarse_planes == 0 || coarse_planes >= 2, "coarse_planes must be 0 (all planes) or >= 2");
  if (regularize) semi_global.Check();
  Require(refine_radius >= 0, "refine_radius must be >= 0 (0: from the coarse level)");
  Require(range_extension_share >= 0.0 && range_extension_share <= 1.0,
          "range_extension_share must be between 0 (never) and 1");
  Require(seed_prior >= 0.0, "seed_prior must be >= 0 (0: off)");
  Require(oversample_max_pixels >= 0, "oversample_max_pixels must be >= 0 (0: never)");
  Require(edge_guard_parallax >= 0.0, "edge_guard_parallax must be >= 0");
  Require(discontinuity_parallax >= 0.0, "discontinuity_parallax must be >= 0");
  Require(discontinuity_relative >= 0.0, "discontinuity_relative must be >= 0");
  Require(discontinuity_radius >= 0, "discontinuity_radius must be >= 0");
  Require(raw_discontinuity_radius >= 0, "raw_discontinuity_radius must be >= 0");
  Require(refine_stride >= 0, "refine_stride must be >= 0 (0: chosen from the parallax)");
  Require(coarse_window_radius >= 0, "coarse_window_radius must be >= 0");
  Require(fine_window_radius >= 0, "fine_window_radius must be >= 0");
  Require(coarse_shiftable_radius >= 0, "coarse_shiftable_radius must be >= 0");
  Require(fine_shiftable_radius >= 0, "fine_shiftable_radius must be >= 0");
  Require(weak_texture_window_radius >= 0, "weak_texture_window_radius must be >= 0");
  Require(weak_texture_gradient >= 0.0, "weak_texture_gradient must be >= 0");
  Require(prefilter_sigma >= 0.0, "prefilter_sigma must be >= 0");
  Require(truncation > 0.0f, "truncation must be > 0");
  Require(min_confidence >= 0.0, "min_confidence must be >= 0");
  Require(guided_radius >= 0, "guided_radius must be >= 0");
  Require(guided_eps > 0.0, "guided_eps must be > 0");
  Require(max_cost_ratio >= 0.0, "max_cost_ratio must be >= 0");
  Require(fine_high_pass_ratio > 0.0, "fine_high_pass_ratio must be > 0");
  if (fill_holes) completion.Check();
}

double DepthFraction(const cv::Mat& depth) {
  if (depth.empty()) return 0.0;
  return static_cast<double>(cv::countNonZero(depth > 0.0f)) / depth.total();
}

int CoarseScale(int width, const DenseOptions& options) {
  if (options.coarse_scale > 0) return options.coarse_scale;
  return std::clamp(static_cast<int>(std::lround(width / kCoarseLevelWidth)), 2, 4);
}

DenseFramesSettings DenseFramesSettingsFor(const DenseOptions& options, int width, int height) {
  DenseFramesSettings settings;
  settings.coarse_high_pass_sigma = HighPassSigma(options.high_pass_sigma_px, width, height);
  settings.prefilter_sigma = options.prefilter_sigma;
  settings.coarse_scale = CoarseScale(width, options);
  // A sweep of every plane at full resolution (coarse_scale 1) is the coarse
  // level's: it keeps the whole sigma.
  settings.fine_high_pass_sigma =
      settings.coarse_scale > 1 ? settings.coarse_high_pass_sigma * options.fine_high_pass_ratio
                                : settings.coarse_high_pass_sigma;
  return settings;
}

int RefineRadius(int width, const DenseOptions& options) {
  if (options.refine_radius > 0) return options.refine_radius;
  return width / CoarseScale(width, options) < kNarrowCoarseLevelWidth ? 4 : 3;
}

DenseDepth ComputeDenseDepth(const Burst& burst, const CameraModel& camera,
                             const std::vector<Pose>& poses,
                             const std::vector<double>& sparse_inverse_depths,
                             const DenseOptions& options, std::optional<DenseFrames> prepared) {
  ValidateInputs(burst, camera, poses, options);
  const DenseFramesSettings settings =
      DenseFramesSettingsFor(options, burst.width(), burst.height());
  const cv::Size size(burst.width(), burst.height());
  if (prepared) ValidatePreparedFrames(*prepared, burst, settings);
  InverseDepthLattice lattice = InverseDepthLattice::FromSparse(
      sparse_inverse_depths, options.inverse_depth_margin, options.planes);
  DenseDepth result;
  StageTimer timer(&result.timings_ms, options.progress);

  // Everything below sees the high-passed frames; the caller's stay as they are.
  SweptFrames swept = TakeSweptFrames(burst, settings, &prepared);
  const RadialInverse radial(camera);
  const SweepPoses sweep_poses = SweepPoses::Make(poses, burst.reference(), options.readout, camera,
                                                  options.frame_times, options.angular_velocities);
  const std::vector<int>& others = sweep_poses.frames;
  std::vector<Pose> other_poses;
  for (int i : others) other_poses.push_back(poses[i]);
  timer.Lap("prepare");

  PhotoCostOptions cost;
  cost.truncation = options.truncation;
  const int scale = settings.coarse_scale;
  SweepLevel coarse = MakeCoarseLevel(burst, camera, radial, sweep_poses, options, scale, &swept);
  cost.window_radius = options.coarse_window_radius;
  cost.shiftable_radius = options.coarse_shiftable_radius;
  CoarseSweep coarse_sweep = SweepCoarseLevel(coarse, camera, other_poses, scale, burst.width(),
                                              options, &lattice, &cost, &result);
  const SweepGeometry& geometry = coarse_sweep.geometry;
  coarse = SweepLevel();  // not read again
  timer.Lap("coarse_sweep");
  CoarsePlanesOntoLattice(geometry, lattice, &coarse_sweep.selection);
  timer.Lap("coarse_lattice");

  cv::Mat plane, confidence;
  if (scale == 1) {
    plane = coarse_sweep.selection.plane;
    confidence = coarse_sweep.selection.confidence;
  } else {
    result.fine_planes = geometry.window;
    result.fine_stride = geometry.stride;
    const FineSeeds seeds = UpsampleCoarseSeeds(coarse_sweep, lattice, size, scale, options);
    const SweepLevel fine = MakeSweepLevel(swept.reference, swept.frames, sweep_poses, camera,
                                           radial, 1, OversampleFactor(burst, options, 1));
    timer.Lap("upsample");
    const PlaneSelection fine_selection =
        SweepFineWindow(fine, lattice, seeds, geometry, options, &cost);
    timer.Lap("fine_sweep");
    plane = fine_selection.plane;
    confidence = seeds.coarse_confidence;
    ClearConfidenceOffTheWindow(fine_selection, lattice, geometry.stride, size, &confidence);
    timer.Lap("fine_confidence");
  }
  // Nothing below reads the swept frames: without them the refinement and
  // the fill, where the stage peaks at 1080p, need 60-70 MB less.
  swept.frames = std::vector<cv::Mat>();
  swept.reference.release();
  cost = PhotoCostOptions();  // the seed and the weak-texture mask

  cv::Mat weight = MeasuredWeight(plane, confidence, options);
  RefinePlanes(swept.high_passed_reference, lattice, geometry.plane_parallax, options, &plane,
               &weight);
  SetMeasuredDepth(plane, weight, confidence, lattice, options, &result);
  timer.Lap("refine");

  if (options.fill_holes && result.valid_fraction < 1.0) {
    FillDepthHoles(plane, burst, swept.high_passed_reference, lattice, options, &result);
    timer.Lap("fill");
  } else if (options.fill_holes) {
    result.depth_filled = result.depth;
  }
  return result;
}

}  // namespace dfsm
