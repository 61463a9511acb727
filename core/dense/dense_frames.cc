#include "core/dense/dense_frames.h"

#include <chrono>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>
#include <utility>

#include "core/dense/high_pass.h"
#include "core/dense/sweep_level.h"
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

DenseFramesMaker::DenseFramesMaker(const Burst& burst, const DenseFramesSettings& settings)
    : burst_(burst), filtered_(burst.size()) {
  made_.settings = settings;
  made_.reference = burst.reference();
  made_.frame_ms.assign(burst.size(), 0.0);
  if (settings.SeparateCoarseFrames()) coarse_.resize(burst.size());
}

void DenseFramesMaker::MakeFrame(int i) {
  const auto start = std::chrono::steady_clock::now();
  const DenseFramesSettings& settings = made_.settings;
  const auto high_passed = [&](double sigma) {
    return sigma > 0.0 ? HighPass(burst_.gray[i], sigma) : burst_.gray[i];
  };
  // The high-passed frame is dropped once filtered, but the reference's.
  const cv::Mat high = high_passed(settings.fine_high_pass_sigma);
  filtered_[i] = Prefiltered(high, settings.prefilter_sigma);
  if (i == made_.reference) made_.reference_gray = high;
  if (settings.SeparateCoarseFrames())
    coarse_[i] = DownsampleToLevel(
        Prefiltered(high_passed(settings.coarse_high_pass_sigma), settings.prefilter_sigma),
        settings.coarse_scale);
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
  if (!coarse_.empty()) {
    made_.coarse_reference = coarse_[made_.reference];
    for (int i = 0; i < frames(); ++i)
      if (i != made_.reference) made_.coarse_others.push_back(coarse_[i]);
  }
  filtered_.clear();
  coarse_.clear();
  return std::move(made_);
}

DenseFrames PrepareDenseFrames(const Burst& burst, const DenseFramesSettings& settings) {
  DenseFramesMaker maker(burst, settings);
  cv::parallel_for_(cv::Range(0, maker.frames()), [&](const cv::Range& range) {
    for (int i = range.start; i < range.end; ++i) maker.MakeFrame(i);
  });
  return maker.Take();
}

}  // namespace dfsm
