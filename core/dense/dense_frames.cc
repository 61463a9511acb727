#include "core/dense/dense_frames.h"

#include <chrono>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>
#include <utility>

#include "core/dense/high_pass.h"
#include "core/io/stage_timer.h"

namespace dfsm {

cv::Mat Prefiltered(const cv::Mat& gray, double sigma) {
  cv::Mat image;
  if (sigma <= 0.0) {
    gray.convertTo(image, CV_32F);
    return image;
  }
  const int size = cvRound(sigma * 8 + 1) | 1;
  const cv::Mat kernel = cv::getGaussianKernel(size, sigma, CV_32F);
  cv::sepFilter2D(gray, image, CV_32F, kernel, kernel, cv::Point(-1, -1), 0.0,
                  cv::BORDER_REPLICATE);
  return image;
}

DenseFramesMaker::DenseFramesMaker(const Burst& burst, double high_pass_sigma_px,
                                   double prefilter_sigma)
    : burst_(burst), filtered_(burst.size()) {
  made_.high_pass_sigma = HighPassSigma(high_pass_sigma_px, burst.width(), burst.height());
  made_.prefilter_sigma = prefilter_sigma;
  made_.reference = burst.reference();
  made_.frame_ms.assign(burst.size(), 0.0);
}

void DenseFramesMaker::MakeFrame(int i) {
  const auto start = std::chrono::steady_clock::now();
  // The high-passed frame is dropped once filtered, but the reference's.
  const cv::Mat high = made_.high_pass_sigma > 0.0 ? HighPass(burst_.gray[i], made_.high_pass_sigma)
                                                   : burst_.gray[i];
  filtered_[i] = Prefiltered(high, made_.prefilter_sigma);
  if (i == made_.reference) made_.reference_gray = high;
  made_.frame_ms[i] = MillisecondsBetween(start);
}

DenseFrames DenseFramesMaker::Take() {
  if (static_cast<int>(filtered_.size()) != frames())
    throw std::logic_error("DenseFramesMaker: the frames were taken already");
  for (int i = 0; i < frames(); ++i)
    if (filtered_[i].empty())
      throw std::logic_error("DenseFramesMaker: frame " + std::to_string(i) + " was not made");
  made_.reference_filtered = filtered_[made_.reference];
  for (int i = 0; i < frames(); ++i)
    if (i != made_.reference) made_.others.push_back(filtered_[i]);
  filtered_.clear();
  return std::move(made_);
}

DenseFrames PrepareDenseFrames(const Burst& burst, double high_pass_sigma_px,
                               double prefilter_sigma) {
  DenseFramesMaker maker(burst, high_pass_sigma_px, prefilter_sigma);
  cv::parallel_for_(cv::Range(0, maker.frames()), [&](const cv::Range& range) {
    for (int i = range.start; i < range.end; ++i) maker.MakeFrame(i);
  });
  return maker.Take();
}

}  // namespace dfsm
