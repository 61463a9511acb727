#include "core/dense/guided_filter.h"

#include <opencv2/imgproc.hpp>

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

cv::Mat Filter(const cv::Mat& guide, const GuideMoments& moments, const cv::Mat& input,
               int radius) {
  const cv::Mat mean_p = Mean(input, radius);
  const cv::Mat covariance = Mean(guide.mul(input), radius) - moments.mean.mul(mean_p);
  const cv::Mat a = covariance / moments.variance_plus_eps;
  const cv::Mat b = mean_p - a.mul(moments.mean);
  return Mean(a, radius).mul(guide) + Mean(b, radius);
}

}  // namespace

cv::Mat GuidedFilter(const cv::Mat& guide, const cv::Mat& input, int radius, float eps) {
  CV_Assert(guide.type() == CV_32FC1 && input.type() == CV_32FC1 && guide.size() == input.size() &&
            radius >= 1 && eps > 0.0f);
  return Filter(guide, GuideMoments(guide, radius, eps), input, radius);
}

cv::Mat WeightedGuidedFilter(const cv::Mat& guide, const cv::Mat& input, const cv::Mat& weight,
                             int radius, float eps, cv::Mat* support) {
  CV_Assert(guide.type() == CV_32FC1 && input.type() == CV_32FC1 && weight.type() == CV_32FC1 &&
            guide.size() == input.size() && guide.size() == weight.size() && radius >= 1 &&
            eps > 0.0f);
  const GuideMoments moments(guide, radius, eps);
  // The two filters are independent: one per worker.
  cv::Mat numerator, denominator;
  cv::parallel_for_(cv::Range(0, 2), [&](const cv::Range& range) {
    for (int n = range.start; n < range.end; ++n) {
      if (n == 0) numerator = Filter(guide, moments, input.mul(weight), radius);
      if (n == 1) denominator = Filter(guide, moments, weight, radius);
    }
  });
  cv::Mat result(input.size(), CV_32FC1);
  for (int y = 0; y < result.rows; ++y) {
    const float* n = numerator.ptr<float>(y);
    const float* d = denominator.ptr<float>(y);
    float* r = result.ptr<float>(y);
    for (int x = 0; x < result.cols; ++x) r[x] = d[x] > 1e-3f ? n[x] / d[x] : 0.0f;
  }
  if (support) *support = denominator;
  return result;
}

}  // namespace dfsm
