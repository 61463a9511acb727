#include "core/dense/depth_completion.h"

#include <algorithm>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <vector>

#include "core/dense/bilinear_upsample.h"
#include "core/dense/guided_filter.h"
#include "core/parallel/parallel_for.h"

namespace dfsm {
namespace {

// A hole whose smoothed weight stays below this (in the units of a measured
// pixel's weight, its confidence to confidence_power, at most 1) lies in a
// region no measurement reaches: it keeps the push-pull fill.
constexpr float kMinSpreadWeight = 1e-4f;

// The 2x2 sums of a level (odd sizes: the last row/column sums what exists).
cv::Mat SumDown(const cv::Mat& level) {
  cv::Mat padded;
  cv::copyMakeBorder(level, padded, 0, level.rows % 2, 0, level.cols % 2, cv::BORDER_CONSTANT, 0);
  cv::Mat sum;
  cv::resize(padded, sum, cv::Size(padded.cols / 2, padded.rows / 2), 0, 0, cv::INTER_AREA);
  return sum * 4.0f;  // INTER_AREA averages: the pyramid carries sums
}

// The confidence-weighted pyramid: level 0 is (value x weight, weight), each
// level above the 2x2 sums of the one below, until a level has no hole.
struct Pyramid {
  std::vector<cv::Mat> value_weight, weights;
};

Pyramid Push(const cv::Mat& values, const cv::Mat& w0) {
  Pyramid pyramid{{values.mul(w0)}, {w0}};
  while (pyramid.weights.back().rows > 1 || pyramid.weights.back().cols > 1) {
    const cv::Mat& top = pyramid.weights.back();
    if (cv::countNonZero(top) == static_cast<int>(top.total())) break;
    pyramid.value_weight.push_back(SumDown(pyramid.value_weight.back()));
    pyramid.weights.push_back(SumDown(top));
  }
  return pyramid;
}

// The pull from the coarsest level down to `level` (whole levels: above 0
// they are a quarter of the image or less): own mean where the weight is
// whole, blended with the coarser level where it is partial or zero.
cv::Mat PullDownTo(const Pyramid& pyramid, int level) {
  cv::Mat filled;
  for (int l = static_cast<int>(pyramid.weights.size()) - 1; l >= level; --l) {
    const cv::Mat& w = pyramid.weights[l];
    cv::Mat mean;
    cv::divide(pyramid.value_weight[l], cv::max(w, 1e-12f), mean);
    if (filled.empty()) {
      filled = mean;
      continue;
    }
    cv::Mat up;
    cv::resize(filled, up, w.size(), 0, 0, cv::INTER_LINEAR);
    cv::Mat alpha;
    cv::min(w, 1.0f, alpha);
    filled = alpha.mul(mean) + (1.0f - alpha).mul(up);
  }
  return filled;
}

// The same step onto level 0, at the pixels of `roi` only, from the pulled
// level 1 (upsampled as cv::resize's INTER_LINEAR aligns it).
cv::Mat PullFinest(const Pyramid& pyramid, const cv::Mat& level1, const cv::Rect& roi) {
  const cv::Mat &value_weight = pyramid.value_weight[0], &w = pyramid.weights[0];
  const UpsampleAxis rows(level1.rows, w.rows), columns(level1.cols, w.cols);
  cv::Mat filled(roi.size(), CV_32FC1);
  ParallelRows(roi.height, [&](int r) {
    const int y = roi.y + r;
    const float *vw = value_weight.ptr<float>(y), *wy = w.ptr<float>(y);
    const float *up0 = level1.ptr<float>(rows.lower[y]),
                *up1 = level1.ptr<float>(rows.lower[y] + rows.step[y]);
    float* out = filled.ptr<float>(r);
    for (int c = 0; c < roi.width; ++c) {
      const int x = roi.x + c;
      const float mean = vw[x] / std::max(wy[x], 1e-12f);
      const float alpha = std::min(wy[x], 1.0f);
      out[c] = alpha * mean + (1.0f - alpha) * Upsampled(up0, up1, rows.t[y], columns, x);
    }
  });
  return filled;
}

// The push-pull fallback (step 2 of depth_completion.h) written into
// `filled` at the pixels of `unreached`. w0: the weights, >= 0; measured:
// where a pixel has a measurement (8-bit mask). Level 0 and the guided pass
// are evaluated around the unreached pixels only: in the tiles of
// options.fallback_tile that hold one, each widened by the guided filter's
// reach (its two box means on the subsampled grid, the bilinear upsampling,
// the 2x2 averaging), so that a tile's pixels read what they read in the
// whole image. (At the whole frame's size this cost 65-90 ms at 1080p for
// 0.04-0.3 % of its pixels.) Where the windows would cover half the image,
// or the guided pass's subsampled grid is not an exact half, the whole image
// is one window.
void PushPull(const cv::Mat& values, const cv::Mat& w0, const cv::Mat& measured,
              const cv::Mat& guide, const DepthCompletionOptions& options, const cv::Mat& unreached,
              cv::Mat* filled) {
  const Pyramid pyramid = Push(values, w0);
  const cv::Mat level1 = PullDownTo(pyramid, 1);  // w0 has a hole: two levels at least
  const cv::Size size = values.size();
  const int subsample = guide.cols > 1000 ? 2 : 1;
  const int small_radius = std::max(1, options.guided_radius / subsample);
  const int margin = options.guided_radius > 0 ? subsample * (2 * small_radius + 3) : 0;

  struct Window {
    cv::Rect tile, roi;
  };
  std::vector<Window> windows;
  double covered = 0.0;
  const int side =
      options.fallback_tile > 0 ? options.fallback_tile : std::max(size.width, size.height);
  for (int y = 0; y < size.height; y += side)
    for (int x = 0; x < size.width; x += side) {
      const cv::Rect tile = cv::Rect(x, y, side, side) & cv::Rect({}, size);
      if (cv::countNonZero(unreached(tile)) == 0) continue;
      const cv::Rect roi =
          cv::Rect(x - margin, y - margin, tile.width + 2 * margin, tile.height + 2 * margin) &
          cv::Rect({}, size);
      windows.push_back({tile, roi});
      covered += roi.area();
    }
  const bool exact_tiles =
      options.guided_radius == 0 || (size.width % subsample == 0 && size.height % subsample == 0);
  if (!exact_tiles || covered >= 0.5 * size.area())
    windows = {{cv::Rect({}, size), cv::Rect({}, size)}};

  const auto fill_window = [&](const Window& window) {
    cv::Mat pulled = PullFinest(pyramid, level1, window.roi);
    // The guided pass: measurements steer, the fill follows the image's
    // edges (of the grey reference: the guided filter's linear models are
    // per channel).
    if (options.guided_radius > 0) {
      cv::Mat gray = guide(window.roi), gray01;
      if (guide.channels() == 3) cv::cvtColor(gray, gray, cv::COLOR_BGR2GRAY);
      gray.convertTo(gray01, CV_32F, 1.0 / 255.0);
      cv::Mat pass_weight = w0(window.roi).clone();
      pass_weight.setTo(options.filled_weight, ~measured(window.roi));
      pulled = WeightedGuidedFilter(gray01, pulled, pass_weight, options.guided_radius,
                                    options.guided_eps, nullptr, subsample);
    }
    const cv::Rect inner = window.tile - window.roi.tl();
    cv::Mat target = (*filled)(window.tile);
    pulled(inner).copyTo(target, unreached(window.tile));
  };
  if (windows.size() == 1) return fill_window(windows.front());
  cv::parallel_for_(cv::Range(0, static_cast<int>(windows.size())), [&](const cv::Range& range) {
    for (int n = range.start; n < range.end; ++n) fill_window(windows[n]);
  });
}

}  // namespace

void DepthCompletionOptions::Check() const {
  if (guided_radius < 0) throw std::invalid_argument("guided_radius must be >= 0");
  if (fallback_tile < 0 || fallback_tile % 2 != 0)
    throw std::invalid_argument("fallback_tile must be even and >= 0 (0: the whole image)");
  if (!(guided_eps > 0.0f)) throw std::invalid_argument("guided_eps must be > 0");
  if (!(filled_weight > 0.0f && filled_weight <= 1.0f))
    throw std::invalid_argument("filled_weight must be in (0, 1]");
  if (!(confidence_power > 0.0)) throw std::invalid_argument("confidence_power must be > 0");
  if (guide_median < 0 || (guide_median > 1 && guide_median % 2 == 0))
    throw std::invalid_argument("guide_median must be 0, 1 or odd");
  smoother.Check();
}

cv::Mat FillHoles(const cv::Mat& values, const cv::Mat& weight, const cv::Mat& guide,
                  const DepthCompletionOptions& options) {
  options.Check();
  CV_Assert(values.type() == CV_32FC1 && weight.type() == CV_32FC1);
  CV_Assert(guide.type() == CV_8UC1 || guide.type() == CV_8UC3);
  CV_Assert(values.size() == weight.size() && values.size() == guide.size());
  cv::Mat w0;
  cv::max(weight, 0.0f, w0);
  // What is measured is decided before the power, which may underflow a
  // small positive confidence to 0.
  const cv::Mat measured = w0 > 0.0f;
  if (cv::countNonZero(measured) == 0) return {};
  if (options.confidence_power != 1.0) cv::pow(w0, options.confidence_power, w0);

  // The holes the spread along the image's regions does not reach.
  cv::Mat filled, unreached = ~measured;
  if (options.smoother.lambda > 0.0) {
    cv::Mat value = values.mul(w0), spread_weight = w0.clone();
    // A new image: the caller's guide (shared data) stays as it is.
    cv::Mat edges;
    if (options.guide_median > 1)
      cv::medianBlur(guide, edges, options.guide_median);
    else
      edges = guide;
    SmoothAlongEdges(edges, {&value, &spread_weight}, options.smoother);
    cv::divide(value, cv::max(spread_weight, kMinSpreadWeight), filled);
    unreached &= spread_weight < kMinSpreadWeight;
  }
  if (cv::countNonZero(unreached) > 0) {
    if (filled.empty()) filled = cv::Mat::zeros(values.size(), CV_32FC1);
    PushPull(values, w0, measured, guide, options, unreached, &filled);
  }
  values.copyTo(filled, measured);  // measured pixels exactly as they were
  return filled;
}

}  // namespace dfsm
