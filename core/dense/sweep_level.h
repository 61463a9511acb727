// The data of the plane sweep at one resolution: every frame on its captured
// (distorted) grid, the undistorted ray of each reference pixel, and each
// other frame's plane-induced homography between undistorted coordinates. A
// sample is mapped back onto a frame's captured grid through RadialInverse,
// so frames are interpolated once, never resampled onto an undistorted grid.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "core/camera/camera_model.h"
#include "core/camera/pose.h"
#include "core/camera/rolling_shutter.h"
#include "core/dense/radial_inverse.h"

namespace dfsm {

// For the plane Z = 1/w of the reference, a reference ray x = (x_u, y_u, 1)
// lands in a frame at the undistorted normalized point dehomogenized from
// H(w) x, H(w) = R + w T e3^T: linear in w.
//
// Under a rolling shutter the pose is that of the frame's row the sample
// lands on, which depends on where it lands: H is the pose at frame row
// `row` (on the frames' grid), and a sample first projected to grid row py
// moves on by (py - row) times the image motion per grid row there,
// g = g0 + g1 x + w (g2 + g3 x) at reference column x and inverse depth w:
// the rotation's flow is linear across a row but for terms in (x / f)^2,
// the translation's linear in w, and a sample moves hundredths of a pixel per
// row. Global shutter: all zero and unread.
struct PlaneHomography {
  float r[9];  // R, row-major
  float t[3];  // T
  float row = 0.0f;
  float gx[4] = {}, gy[4] = {};
};

struct SweepLevel {
  int scale = 1;         // captured pixels per pixel of this level
  cv::Mat reference;     // CV_32FC1, reference frame
  cv::Mat ray_x, ray_y;  // CV_32FC1, undistorted normalized coords of the reference pixels
  // CV_32FC1, the other frames; on a grid `oversample` times as fine as the
  // level when oversample is 2 (frame_oversampling.h): level position p is
  // frame grid position oversample * p.
  std::vector<cv::Mat> frames;
  int oversample = 1;
  // Per entry of `frames`: one homography (a global shutter), or one per row
  // of the level (a rolling shutter: each reference row seen from its own
  // row's pose, the frame's sample taken at the time of the row it lands on).
  std::vector<std::vector<PlaneHomography>> warps;
  bool rolling_shutter() const { return !warps.empty() && warps[0].size() > 1; }
  const PlaneHomography& Warp(int frame, int y) const {
    const std::vector<PlaneHomography>& rows = warps[frame];
    return rows.size() == 1 ? rows[0] : rows[y];
  }
  const RadialInverse* radial = nullptr;
  // Captured pixel p = c + f * ratio * x_u is level pixel (p - (scale - 1) / 2) / scale
  // = centre + focal * ratio * x_u.
  float focal = 0.0f, centre_x = 0.0f, centre_y = 0.0f;
};

// The frames' poses relative to the reference, each frame's at every captured
// row (a rolling shutter) or one pose per frame (a global shutter).
struct SweepPoses {
  // Under a rolling shutter, captured row y of the reference against frame i:
  // the pose of frame row `row`, where the row's centre pixel lands at
  // infinity, and the pose of frame row `row` + 1 (the path's step per row
  // there; a sample's own row is read from where it lands, SweepLevel).
  struct RowPose {
    Pose at, next;
    double row = 0.0;
  };
  std::vector<int> frames;  // burst index of each swept frame (the reference excluded)
  // Per swept frame: one pose (a global shutter), or one per captured row of
  // the reference (a rolling shutter).
  std::vector<std::vector<RowPose>> relative;

  // times: the frames' capture times, velocities: their angular velocities
  // (rolling_shutter.h; empty: consecutive, the line between frame poses).
  static SweepPoses Make(const std::vector<Pose>& poses, int reference, double readout,
                         const CameraModel& camera, const std::vector<double>& times = {},
                         const AngularVelocities& velocities = {});
};

// `image` area-downsampled by the integer `scale` (itself where 1): pixel x
// averages captured pixels scale * x .. scale * x + scale - 1, so its centre
// lies at scale * x + (scale - 1) / 2.
cv::Mat DownsampleToLevel(const cv::Mat& image, int scale);

// Builds the level `scale` (1: full resolution; > 1: area-downsampled by that
// factor, pixel centres at scale * x + (scale - 1) / 2 of the captured grid)
// from float images of the captured size (downsampled here) or already of the
// level's (camera.width / scale, as DownsampleToLevel makes them), its
// frames oversampled by `oversample` (1 or 2). `frames[n]` and
// `poses.relative[n]` belong together; the reference itself is not among
// them. `radial` must outlive the level.
SweepLevel MakeSweepLevel(const cv::Mat& reference, const std::vector<cv::Mat>& frames,
                          const SweepPoses& poses, const CameraModel& camera,
                          const RadialInverse& radial, int scale, int oversample = 1);

}  // namespace dfsm
