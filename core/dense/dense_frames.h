// The frames the plane sweep compares, made from a burst's gray frames alone:
// each high-passed (high_pass.h) and Gaussian-prefiltered into float, and
// where the coarse level's high-pass differs, a second time at its sigma and
// downsampled to it. They do not depend on the poses, so the pipeline has
// them made while the sparse stage runs, on a core its focal-start probe
// leaves idle, instead of after it
// (docs/experiments/207-frames-beside-sparse.md).
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "core/io/burst.h"

namespace dfsm {

// What DenseFrames are made with, resolved for one burst
// (DenseFramesSettingsFor in dense_depth.h reads them off DenseOptions).
struct DenseFramesSettings {
  // HighPass sigmas, pixels (0: none): of the frames the full-resolution
  // window compares, and of those the coarse level compares.
  double fine_high_pass_sigma = 0.0;
  double coarse_high_pass_sigma = 0.0;
  double prefilter_sigma = 0.0;
  int coarse_scale = 1;  // captured pixels per coarse pixel

  // Whether the coarse level needs frames of its own: where the two sigmas
  // agree, it is downsampled from the full-resolution frames (and at
  // coarse_scale 1 it is the full resolution: DenseFramesSettingsFor gives
  // both the same sigma there).
  bool SeparateCoarseFrames() const {
    return coarse_scale > 1 && coarse_high_pass_sigma != fine_high_pass_sigma;
  }
  bool operator==(const DenseFramesSettings& o) const {
    return fine_high_pass_sigma == o.fine_high_pass_sigma &&
           coarse_high_pass_sigma == o.coarse_high_pass_sigma &&
           prefilter_sigma == o.prefilter_sigma && coarse_scale == o.coarse_scale;
  }
};

struct DenseFrames {
  // What they were made with and the burst's reference index
  // (ComputeDenseDepth refuses frames made otherwise, or of a burst of
  // another size, frame count or reference).
  DenseFramesSettings settings;
  int reference = -1;
  // The reference high-passed at the fine sigma, 8-bit: the refinement's
  // guide, and the fill's where the burst has no colour.
  cv::Mat reference_gray;
  // CV_32FC1, high-passed at the fine sigma and prefiltered: the reference
  // and every other frame in burst order (the reference left out), as the
  // full-resolution window samples them.
  cv::Mat reference_filtered;
  std::vector<cv::Mat> others;
  // Where settings.SeparateCoarseFrames(): the same, high-passed at the
  // coarse sigma, prefiltered and downsampled to the coarse level
  // (DownsampleToLevel); empty otherwise.
  cv::Mat coarse_reference;
  std::vector<cv::Mat> coarse_others;
  // The time each frame took to make, by burst index, wherever it was made.
  std::vector<double> frame_ms;
};

// `sigma` <= 0: the frame as float. The Gaussian kernel is GaussianBlur's for
// float images (size 8 sigma + 1, odd), in one separable pass straight from 8
// bits, so no converted copy is made first.
cv::Mat Prefiltered(const cv::Mat& gray, double sigma);

// DenseFrames made one frame at a time: each frame is a piece of work of its
// own, so that a caller can share them out among threads (core/parallel/shared_work.h).
// The burst must outlive the maker.
class DenseFramesMaker {
 public:
  // `burst`: 8-bit gray frames of one size.
  DenseFramesMaker(const Burst& burst, const DenseFramesSettings& settings);

  int frames() const { return burst_.size(); }
  // Makes frame i; distinct frames may be made at once, from any threads.
  void MakeFrame(int i);
  // The frames, once every one is made (std::logic_error otherwise); once.
  DenseFrames Take();

 private:
  const Burst& burst_;
  DenseFrames made_;
  std::vector<cv::Mat> filtered_;
  std::vector<cv::Mat> coarse_;  // empty unless SeparateCoarseFrames()
};

// Every frame of `burst`, made on OpenCV's pool (one after the other where
// the caller is inside a parallel region already: OpenCV runs nested regions
// serially).
DenseFrames PrepareDenseFrames(const Burst& burst, const DenseFramesSettings& settings);

}  // namespace dfsm
