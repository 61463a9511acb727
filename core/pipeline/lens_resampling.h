// Frames captured through a lens that ha2016-d2u holds only approximately
// (core/camera/opencv_lens.h), resampled onto the pixel grid of the model
// fitted to it, and the dense stage's maps taken back onto the captured grid.
//
// A known calibration in OpenCV's model is fitted to ha2016-d2u: TUM's
// freiburg1 camera to 1.73 px RMS at 640x480. A misplacement that varies over
// the image moves each point by the misfit's change along its path, tenths of
// a pixel over the tens of pixels a hand's rotation carries it, where the
// parallax that measures depth is a few pixels. Resampled, the frames follow
// the fitted model exactly. The result keeps the contract's geometry: the
// depth map is on the captured grid (CONTRACT.md section 3).
#pragma once

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "core/camera/camera_model.h"
#include "core/camera/opencv_lens.h"
#include "core/io/burst.h"

namespace dfsm {

class LensResampling {
 public:
  // Maps for `model`'s image size; `model` is the ha2016-d2u fit of `lens`.
  LensResampling(const OpenCvLens& lens, const CameraModel& model);

  // A captured image (any type OpenCV remaps) on the model's grid, bilinear
  // (or cv::INTER_NEAREST for a depth map); where the lens sees outside the
  // frame, the frame's border is repeated. Bilinear, not OpenCV's bicubic:
  // the bicubic moved a spot 0.06 px from where the model puts it, the
  // bilinear 0.02 px, at half the cost (lens_resampling_test).
  cv::Mat IntoModel(const cv::Mat& captured, int interpolation = cv::INTER_LINEAR) const;
  // The burst's frames and reference colour on the model's grid.
  Burst IntoModel(const Burst& burst) const;
  // A map on the model's grid (depth, confidence) on the captured grid: each
  // captured pixel takes the value of the model pixel nearest its own ray,
  // so that a depth is never blended across an edge; 0 outside the model's
  // grid.
  cv::Mat BackToCaptured(const cv::Mat& on_model) const;

  // How far the resampling moves a pixel: the RMS and the largest over the
  // image, in pixels.
  double rms_shift_px() const { return rms_shift_px_; }
  double max_shift_px() const { return max_shift_px_; }

 private:
  cv::Size size_;
  // cv::remap's fixed-point maps: the captured pixel of each model pixel,
  // and the model pixel nearest the ray of each captured pixel.
  cv::Mat into_xy_, into_fraction_;
  cv::Mat back_xy_;
  double rms_shift_px_ = 0.0;
  double max_shift_px_ = 0.0;
};

}  // namespace dfsm
