// Dense depth of the reference frame by plane sweep (step 5 of the method).
#pragma once

#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/camera/camera_model.h"
#include "core/camera/pose.h"
#include "core/camera/rolling_shutter.h"
#include "core/dense/dense_frames.h"
#include "core/dense/depth_completion.h"
#include "core/dense/semi_global.h"
#include "core/io/burst.h"
#include "core/io/progress.h"

namespace dfsm {

struct DenseOptions {
  // The sweep's planes; dfsm and dfsmd accept [kMinPlanes, kMaxPlanes].
  static constexpr int kMinPlanes = 2, kMaxPlanes = 1024;
  int planes = 128;
  // The rolling shutter's readout the poses are for (core/camera/rolling_shutter.h;
  // the sparse stage's SparseState::readout), 0 a global shutter: each
  // reference row is swept with the poses of its own row.
  double readout = 0.0;
  // The frames' capture times the rows' path between frames follows
  // (SparseState::frame_times); empty: consecutive frames.
  std::vector<double> frame_times;
  // Each frame's angular velocity where the sparse stage estimated them
  // (SparseState::angular_velocities); empty: the rows turn along the line
  // between frame poses.
  AngularVelocities angular_velocities;
  // Fraction of the sparse inverse-depth range added on both sides of the sweep.
  double inverse_depth_margin = 0.2;
  // Where more than this share of the confident coarse pixels win the
  // nearest plane of the swept range (a surface nearer than every track), the
  // range is extended toward the camera by its own width and the coarse level
  // swept again, once; 0: never. (A 1080p burst whose nearest photograph had
  // no inlier track: 18 % of its pixels at the near end, the photograph 60 %
  // too far; docs/experiments/228-depth-sweep.md.)
  double range_extension_share = 0.03;

  // Coarse-to-fine: every plane is swept at 1/coarse_scale of the resolution;
  // full resolution then searches 2 * refine_radius + 1 planes of the same
  // lattice around the upsampled coarse winner. coarse_scale 1 sweeps every
  // plane at full resolution (slow; for comparisons). 0: the integer in [2, 4]
  // nearest width / 480 (4 from 1680 px wide: 1080p; 3 from 1200: 720p; 2
  // below, where a 1/4 level is too small to seed the narrow window: on the
  // 512x288 flower burst 47 % of the pixels got a depth at 1/4, 85 % at 1/2;
  // see kCoarseLevelWidth in dense_depth.cc).
  int coarse_scale = 0;
  // Planes of the coarse sweep, spanning the same range. 0: as many as give
  // 0.15 coarse pixels of parallax between neighbours (at most `planes`): at
  // 1/4 resolution the planes of a 128-lattice are often only a few
  // hundredths of a coarse pixel apart, and a denser coarse lattice than
  // that gains nothing at a price (0.1 against 0.15 at 1080p: 1.98 against
  // 1.99 % filled, twice the coarse sweep;
  // docs/experiments/241-coarse-plane-spacing.md).
  int coarse_planes = 0;
  // Semi-global aggregation of the coarse cost volume (semi_global.h) before
  // its winners seed the full-resolution window: a pixel whose own curve is
  // flat or ambiguous (no texture, repetitive texture) is seeded with the
  // depth its surroundings support instead of a random plane, and its
  // confidence stays what its own curve gives that depth. false: each coarse
  // pixel's own winner (winner-take-all). The volume is materialized (at
  // most coarse width x height x coarse planes floats, twice: costs and sums).
  bool regularize = true;
  SemiGlobalOptions semi_global;
  // Photo-consistency outliers (with `regularize`): a coarse pixel whose own
  // cost at its regularized depth exceeds this many times the image's median
  // of that cost is not measured (RejectCostOutliers). No depth of a static
  // scene explains its frames: something that moved, an occlusion, a
  // reflection. 0: off.
  double max_cost_ratio = 3.0;
  // The full-resolution window: 2 * refine_radius + 1 planes, refine_stride
  // lattice planes apart (0: the stride that puts ~0.35 pixel of parallax
  // between them), so the window spans a similar parallax at every lattice
  // density. refine_radius 0: 4 where the coarse level is narrower than 400
  // columns (bursts under 800 px wide), 3 elsewhere (RefineRadius).
  int refine_radius = 0;
  int refine_stride = 0;
  // The upsampled coarse winner as a prior in that window (SeedPrior,
  // plane_selection.h): a plane d pixels of parallax (in the frame that moves
  // most) from the seed costs seed_prior x d^2 grey levels more. The coarse
  // winner was regularized over its surroundings, the full-resolution curve
  // of a weakly textured or noisy pixel is shallow: there the seed decides,
  // where texture is sharp the curve does. 0: off.
  // docs/experiments/222-seed-prior.md.
  double seed_prior = 0.1;
  // Aggregation window half-widths (pixels of the respective level).
  int coarse_window_radius = 2;
  int fine_window_radius = 3;
  // Shiftable windows (PhotoCostOptions::shiftable_radius), level pixels.
  // Coarse 1 keeps the seeds of the near surface from spreading into the far
  // one: at 640x480 the pixels within 2 px of a depth edge went from 13-15 %
  // to 3-5 % AbsRel and coverage rose by 1 point; in the full-resolution
  // window (radius 2) it added noise inside surfaces: 1080p 0.43 -> 0.50 %.
  int coarse_shiftable_radius = 1;
  int fine_shiftable_radius = 0;
  // Weakly textured pixels (weak_texture.h) aggregate over windows of this
  // half-width at full resolution; a window counts as weak where its RMS
  // gradient is below weak_texture_gradient grey levels per pixel. 0: off.
  int weak_texture_window_radius = 7;
  double weak_texture_gradient = 8.0;
  // Gaussian pre-filter of every frame (captured pixels): evens out the blur
  // of bilinear resampling and the sensor/JPEG noise. 0: none. Wider filters
  // wash out the fine texture that low-contrast regions match on: 0.8 gave
  // 2.5-3.1 % AbsRel at 640x480 where 0.5 gives 1.4-1.9 % (docs/dense.md, "Stages", step 1).
  double prefilter_sigma = 0.5;
  // Every frame is high-passed before anything else (high_pass.h): the
  // sweeps, the weak-texture mask and the guided filter's guide all see the
  // frames less their Gaussian blur, of this sigma at the coarse level and of
  // fine_high_pass_ratio times it elsewhere. 0: 1/80 of the longer side;
  // negative: the frames as they are. It costs the ideal generated bursts
  // 0.6-1.6 points of AbsRel (no brightness change to remove, and the low
  // frequencies go too) and gives real footage most of its accuracy back.
  double high_pass_sigma_px = 0.0;
  // The full-resolution window compares frames high-passed at this fraction
  // of that sigma; the coarse level keeps the whole sigma (its own frames,
  // made beside the full-resolution ones where the two differ). A narrower
  // blur mixes less of a nearer surface into a farther one's frames
  // (docs/experiments/219-high-pass-ideal-bursts.md), and the
  // window, 7x7 or 15x15, needs none of the low frequencies it takes out; the
  // coarse level's regularization and confidence, which also decide what is
  // measured at all, keep them. 0.6 against 1: TUM fr1/xyz medians 3.88 ->
  // 3.75 % (filled 6.00 -> 5.97 %), the phone preset's 640x480 defaults 3.24
  // -> 3.05 % (docs/experiments/242-fine-high-pass.md).
  double fine_high_pass_ratio = 0.6;
  // Frames of a sweep level with at most this many pixels are sampled on a
  // grid twice as fine, interpolated once with a cubic (frame_oversampling.h):
  // bilinear samples alone pull the winners towards whole pixels of parallax.
  // It quadruples the frames' memory, so large levels skip it. 0: never.
  int oversample_max_pixels = 1500000;
  float truncation = 10.0f;  // grey levels, see PhotoCostOptions
  // Pixels whose confidence (distinctiveness of the cost minimum) is lower get no depth.
  double min_confidence = 0.05;
  // Edge-aware refinement: confidence-weighted guided filter on inverse depth,
  // guided by the reference image. radius 0: off. 12 since the breaks among
  // the raw winners keep its halos off depth edges (8 before: every size of
  // the phone preset's defaults better, TUM's medians within 0.03 points;
  // docs/experiments/244-refinement-radius.md).
  int guided_radius = 12;
  double guided_eps = 1e-3;  // on a [0, 1] guide
  // The guided filter's linear models are fitted at 1/guided_subsample of the
  // resolution (fast guided filter) once the image is wider than 1000 pixels.
  int guided_subsample = 2;
  // Depth discontinuities (see depth_discontinuity.h), in pixels of parallax
  // (in the frame that moves most): where the refinement departs from the
  // median of the raw winners by more than edge_guard_parallax, or lies within
  // guided_radius + discontinuity_radius of a break in that median, it keeps
  // the median; pixels within discontinuity_radius of which the depth spans more
  // than discontinuity_parallax get no depth. 0: off.
  double edge_guard_parallax = 0.2;
  int discontinuity_radius = 2;
  // ... and, where the refinement is on (guided_radius > 0), pixels within
  // raw_discontinuity_radius of which the raw winners (before it) span such a
  // break: there the refinement hands a pixel one side's depth, at a depth
  // edge the nearer surface's on the farther one's pixels, and the fill does
  // better (docs/experiments/224-breaks-among-raw-winners.md). 0: off.
  int raw_discontinuity_radius = 4;
  double discontinuity_parallax = 0.6;
  // ... and more than this fraction of the larger inverse depth.
  double discontinuity_relative = 0.2;
  // DenseDepth::depth_filled: every pixel, the holes filled from their
  // measured surroundings (depth_completion.h). false: not computed.
  bool fill_holes = true;
  DepthCompletionOptions completion;
  // Hears each lap of the stage as it ends (core/io/progress.h).
  ProgressCallback progress;

  // Throws std::invalid_argument ("dense: ...") naming the option out of its
  // range.
  void Check() const;
};

struct DenseDepth {
  cv::Mat depth;  // CV_32FC1 on the reference frame's captured (distorted) grid; 0 = none
  // CV_32FC1 in [0, 1] on the same grid; 0 wherever depth is 0, so with a
  // positive min_confidence depth > 0 exactly where it is >= min_confidence.
  cv::Mat confidence;
  double min_confidence = 0.0;  // DenseOptions::min_confidence, as used
  // `depth` with every hole filled (fill_holes); empty when off or when there
  // was no measurement to fill from. Where depth > 0 the two are equal.
  cv::Mat depth_filled;
  double min_inverse_depth = 0.0;  // the swept range
  double max_inverse_depth = 0.0;
  int planes = 0;
  // Whether the range was extended toward the camera (range_extension_share).
  bool range_extended = false;
  int coarse_scale = 0;         // captured pixels per coarse pixel
  int coarse_planes = 0;        // planes of the coarse sweep
  int fine_planes = 0;          // planes per pixel at full resolution ...
  int fine_stride = 0;          // ... this many lattice planes apart
  double valid_fraction = 0.0;  // share of pixels with depth > 0
  // Share of the coarse pixels left unmeasured as photo-consistency outliers
  // (DenseOptions::max_cost_ratio).
  double outlier_fraction = 0.0;
  std::vector<std::pair<std::string, double>> timings_ms;  // sub-stages, in order
};

// The share of the pixels of a depth map (CV_32FC1) with a depth > 0
// (DenseDepth::valid_fraction); 0 for an empty map.
double DepthFraction(const cv::Mat& depth);

// The coarse level's scale for a burst `width` pixels wide: options.coarse_scale
// where positive, the default rule (DenseOptions::coarse_scale) otherwise.
int CoarseScale(int width, const DenseOptions& options);

// The settings of the frames ComputeDenseDepth compares for a burst `width`
// x `height` pixels (HighPassSigma, fine_high_pass_ratio, CoarseScale).
DenseFramesSettings DenseFramesSettingsFor(const DenseOptions& options, int width, int height);

// The full-resolution window's half-width in planes for a burst `width`
// pixels wide: options.refine_radius where positive, the default rule
// (DenseOptions::refine_radius) otherwise.
int RefineRadius(int width, const DenseOptions& options);

// `poses` are X_i = R_i X_ref + T_i for every frame of `burst` (reference
// included); `sparse_inverse_depths` are the inverse depths (same scale as T)
// of the sparse tracks, used to choose the swept range. `prepared`: the
// frames PrepareDenseFrames made of this burst with DenseFramesSettingsFor
// (made here where absent; their memory is given up as the stage goes, so
// pass them moved). Throws std::invalid_argument
// naming the problem for inputs and options out of range, and for prepared
// frames made of another burst or with other options.
DenseDepth ComputeDenseDepth(const Burst& burst, const CameraModel& camera,
                             const std::vector<Pose>& poses,
                             const std::vector<double>& sparse_inverse_depths,
                             const DenseOptions& options = {},
                             std::optional<DenseFrames> prepared = std::nullopt);

}  // namespace dfsm
