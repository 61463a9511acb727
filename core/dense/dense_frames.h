// The frames the plane sweep compares, made from a burst's gray frames alone:
// each high-passed (high_pass.h) and Gaussian-prefiltered into float. They do
// not depend on the poses, so the pipeline has them made while the sparse
// stage runs, on a core its focal-start probe leaves idle, instead of after it
// (docs/dense.md, "The sweep's frames made beside the sparse stage").
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "core/io/burst.h"

namespace dfsm {

struct DenseFrames {
  // What they were made with (ComputeDenseDepth refuses frames made
  // otherwise, or of a burst of another size, frame count or reference):
  // HighPassSigma's sigma as used (0: none), the prefilter's sigma, the
  // burst's reference index.
  double high_pass_sigma = 0.0;
  double prefilter_sigma = 0.0;
  int reference = -1;
  // The reference high-passed, 8-bit: the refinement's guide, and the fill's
  // where the burst has no colour.
  cv::Mat reference_gray;
  // CV_32FC1, prefiltered: the reference and every other frame in burst order
  // (the reference left out), as the sweeps sample them.
  cv::Mat reference_filtered;
  std::vector<cv::Mat> others;
  // The time each frame took to make, by burst index, wherever it was made.
  std::vector<double> frame_ms;
};

// `sigma` <= 0: the frame as float. The Gaussian kernel is GaussianBlur's for
// float images (size 8 sigma + 1, odd), in one separable pass straight from 8
// bits, so no converted copy is made first.
cv::Mat Prefiltered(const cv::Mat& gray, double sigma);

// DenseFrames made one frame at a time: each frame is a piece of work of its
// own, so that a caller can share them out among threads (core/io/shared_work.h).
// The burst must outlive the maker.
class DenseFramesMaker {
 public:
  // `burst`: 8-bit gray frames of one size; the high-pass sigma is
  // HighPassSigma(high_pass_sigma_px, width, height).
  DenseFramesMaker(const Burst& burst, double high_pass_sigma_px, double prefilter_sigma);

  int frames() const { return burst_.size(); }
  // Makes frame i; distinct frames may be made at once, from any threads.
  void MakeFrame(int i);
  // The frames, once every one is made (std::logic_error otherwise); once.
  DenseFrames Take();

 private:
  const Burst& burst_;
  DenseFrames made_;
  std::vector<cv::Mat> filtered_;
};

// Every frame of `burst`, made on OpenCV's pool (one after the other where
// the caller is inside a parallel region already: OpenCV runs nested regions
// serially).
DenseFrames PrepareDenseFrames(const Burst& burst, double high_pass_sigma_px,
                               double prefilter_sigma);

}  // namespace dfsm
