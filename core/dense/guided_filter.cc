#include "core/dense/guided_filter.h"

#include <algorithm>
#include <opencv2/imgproc.hpp>

#include "core/dense/parallel_rows.h"

namespace dfsm {
namespace {

cv::Mat Mean(const cv::Mat& image, int radius) {
  cv::Mat mean;
  cv::boxFilter(image, mean, CV_32F, cv::Size(2 * radius + 1, 2 * radius + 1), cv::Point(-1, -1),
                true, cv::BORDER_REPLICATE);
  return mean;
}

// The guide's statistics, shared by every input filtered with it.
struct GuideMoments {
  cv::Mat mean, variance_plus_eps;
  GuideMoments(const cv::Mat& guide, int radius, float eps) {
    mean = Mean(guide, radius);
    variance_plus_eps = Mean(guide.mul(guide), radius) - mean.mul(mean) + eps;
  }
};

// The window means of the local linear model q = a I + b fitted to `input`.
struct LinearModel {
  cv::Mat a, b;
};

LinearModel Fit(const cv::Mat& guide, const GuideMoments& moments, const cv::Mat& input,
                int radius) {
  const cv::Mat mean_p = Mean(input, radius);
  const cv::Mat covariance = Mean(guide.mul(input), radius) - moments.mean.mul(mean_p);
  const cv::Mat a = covariance / moments.variance_plus_eps;
  const cv::Mat b = mean_p - a.mul(moments.mean);
  return {Mean(a, radius), Mean(b, radius)};
}

// q = a I + b on the full-resolution guide; a and b come from the subsampled
// fit (the "fast guided filter" of He and Sun, 2015): they vary smoothly, the
// edges come from I itself.
cv::Mat Apply(const LinearModel& model, const cv::Mat& full_guide) {
  if (model.a.size() == full_guide.size()) return model.a.mul(full_guide) + model.b;
  cv::Mat a, b;
  cv::resize(model.a, a, full_guide.size(), 0, 0, cv::INTER_LINEAR);
  cv::resize(model.b, b, full_guide.size(), 0, 0, cv::INTER_LINEAR);
  return a.mul(full_guide) + b;
}

cv::Mat Subsampled(const cv::Mat& image, int subsample) {
  if (subsample == 1) return image;
  cv::Mat small;
  cv::resize(image, small, cv::Size(image.cols / subsample, image.rows / subsample), 0, 0,
             cv::INTER_AREA);
  return small;
}

}  // namespace

cv::Mat GuidedFilter(const cv::Mat& guide, const cv::Mat& input, int radius, float eps) {
  CV_Assert(guide.type() == CV_32FC1 && input.type() == CV_32FC1 && guide.size() == input.size() &&
            radius >= 1 && eps > 0.0f);
  return Apply(Fit(guide, GuideMoments(guide, radius, eps), input, radius), guide);
}

cv::Mat WeightedGuidedFilter(const cv::Mat& guide, const cv::Mat& input, const cv::Mat& weight,
                             int radius, float eps, cv::Mat* support, int subsample) {
  CV_Assert(guide.type() == CV_32FC1 && input.type() == CV_32FC1 && weight.type() == CV_32FC1 &&
            guide.size() == input.size() && guide.size() == weight.size() && radius >= 1 &&
            eps > 0.0f && subsample >= 1);
  const int small_radius = std::max(1, radius / subsample);
  const cv::Mat small_guide = Subsampled(guide, subsample);
  const GuideMoments moments(small_guide, small_radius, eps);
  // The two filters are independent: one per worker.
  cv::Mat numerator, denominator;
  cv::parallel_for_(cv::Range(0, 2), [&](const cv::Range& range) {
    for (int n = range.start; n < range.end; ++n) {
      if (n == 0)
        numerator =
            Apply(Fit(small_guide, moments, Subsampled(input.mul(weight), subsample), small_radius),
                  guide);
      if (n == 1)
        denominator =
            Apply(Fit(small_guide, moments, Subsampled(weight, subsample), small_radius), guide);
    }
  });
  cv::Mat result(input.size(), CV_32FC1);
  ParallelRows(result.rows, [&](int y) {
    const float* n = numerator.ptr<float>(y);
    const float* d = denominator.ptr<float>(y);
    float* r = result.ptr<float>(y);
    for (int x = 0; x < result.cols; ++x) r[x] = d[x] > 1e-3f ? n[x] / d[x] : 0.0f;
  });
  if (support) *support = denominator;
  return result;
}

}  // namespace dfsm
