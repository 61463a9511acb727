#include "core/dense/depth_completion.h"

#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <vector>

#include "core/dense/guided_filter.h"

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

// Every pixel from the measured ones: the push-pull pyramid, then the guided
// pass over the holes (steps 1-2 of depth_completion.h). w0: the weights, >= 0;
// measured: where a pixel has a measurement (8-bit mask).
cv::Mat PushPull(const cv::Mat& values, const cv::Mat& w0, const cv::Mat& measured,
                 const cv::Mat& guide, const DepthCompletionOptions& options) {
  // Push: levels of (sum of value x weight, sum of weight) until no hole.
  std::vector<cv::Mat> value_weight{values.mul(w0)}, weights{w0};
  while (weights.back().rows > 1 || weights.back().cols > 1) {
    if (cv::countNonZero(weights.back()) == static_cast<int>(weights.back().total())) break;
    value_weight.push_back(SumDown(value_weight.back()));
    weights.push_back(SumDown(weights.back()));
  }
  // Pull: from the coarsest level down, own mean where the weight is whole,
  // blended with the coarser level where it is partial or zero.
  cv::Mat filled;
  for (int level = static_cast<int>(weights.size()) - 1; level >= 0; --level) {
    const cv::Mat& w = weights[level];
    cv::Mat mean;
    cv::divide(value_weight[level], cv::max(w, 1e-12f), mean);
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
  // The guided pass: measurements steer, the fill follows the image's edges
  // (of the grey reference: the guided filter's linear models are per channel).
  if (options.guided_radius > 0) {
    cv::Mat gray = guide, gray01;
    if (guide.channels() == 3) cv::cvtColor(guide, gray, cv::COLOR_BGR2GRAY);
    gray.convertTo(gray01, CV_32F, 1.0 / 255.0);
    cv::Mat pass_weight = w0.clone();
    pass_weight.setTo(options.filled_weight, ~measured);
    const cv::Mat smoothed =
        WeightedGuidedFilter(gray01, filled, pass_weight, options.guided_radius, options.guided_eps,
                             nullptr, guide.cols > 1000 ? 2 : 1);
    smoothed.copyTo(filled, ~measured);
  }
  return filled;
}

}  // namespace

void DepthCompletionOptions::Check() const {
  if (guided_radius < 0) throw std::invalid_argument("guided_radius must be >= 0");
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
    const cv::Mat pushed = PushPull(values, w0, measured, guide, options);
    if (filled.empty())
      filled = pushed;
    else
      pushed.copyTo(filled, unreached);
  }
  values.copyTo(filled, measured);  // measured pixels exactly as they were
  return filled;
}

}  // namespace dfsm
