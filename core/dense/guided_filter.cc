#include "core/dense/guided_filter.h"

#include <algorithm>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "core/dense/bilinear_upsample.h"
#include "core/parallel/parallel_for.h"

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

// q = a I + b, a and b fitted on `guide` itself.
cv::Mat Apply(const LinearModel& model, const cv::Mat& guide) {
  return model.a.mul(guide) + model.b;
}

// WeightedGuidedFilter applies models fitted at 1/subsample of the
// resolution to the full-resolution guide (the "fast guided filter" of He and
// Sun, 2015): a and b vary smoothly, the edges come from I itself.
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
  // The two fits are independent: one per worker.
  LinearModel numerator, denominator;
  cv::parallel_for_(cv::Range(0, 2), [&](const cv::Range& range) {
    for (int n = range.start; n < range.end; ++n) {
      if (n == 0)
        numerator =
            Fit(small_guide, moments, Subsampled(input.mul(weight), subsample), small_radius);
      if (n == 1)
        denominator = Fit(small_guide, moments, Subsampled(weight, subsample), small_radius);
    }
  });
  // Applying both models and dividing is one pass over the full-resolution
  // guide, upsampling a and b on the fly: at 1080p the separate upsampled
  // maps and products were nine full-size images (75 MB) written once and read once.
  cv::Mat result(input.size(), CV_32FC1);
  if (support) support->create(input.size(), CV_32FC1);
  const cv::Size small = numerator.a.size();
  const UpsampleAxis rows(small.height, input.rows), columns(small.width, input.cols);
  ParallelRows(result.rows, [&](int y) {
    const int r0 = rows.lower[y], r1 = r0 + rows.step[y];
    const float ty = rows.t[y];
    const float* guide_row = guide.ptr<float>(y);
    float* r = result.ptr<float>(y);
    float* s = support ? support->ptr<float>(y) : nullptr;
    const float *na0 = numerator.a.ptr<float>(r0), *na1 = numerator.a.ptr<float>(r1);
    const float *nb0 = numerator.b.ptr<float>(r0), *nb1 = numerator.b.ptr<float>(r1);
    const float *da0 = denominator.a.ptr<float>(r0), *da1 = denominator.a.ptr<float>(r1);
    const float *db0 = denominator.b.ptr<float>(r0), *db1 = denominator.b.ptr<float>(r1);
    for (int x = 0; x < result.cols; ++x) {
      const float g = guide_row[x];
      const float n = Upsampled(na0, na1, ty, columns, x) * g + Upsampled(nb0, nb1, ty, columns, x);
      const float d = Upsampled(da0, da1, ty, columns, x) * g + Upsampled(db0, db1, ty, columns, x);
      r[x] = d > 1e-3f ? n / d : 0.0f;
      if (s) s[x] = d;
    }
  });
  return result;
}

}  // namespace dfsm
