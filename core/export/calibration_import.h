// Known calibrations read into dfsm's camera model: dfsm's own calibration.json
// and calibration.yaml, an OpenCV FileStorage file (YAML, XML or JSON) and a ROS
// CameraInfo YAML. OpenCV's distortion runs Undistorted -> Distorted with
// tangential and rational terms that ha2016-d2u cannot hold, so those files are
// fitted, and the fit's error in pixels is reported beside the result.
#pragma once

#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/camera/camera_model.h"
#include "core/camera/opencv_lens.h"

namespace dfsm {

// Every problem with a calibration file or its values: what() names the file
// (when there is one) and the problem.
class CalibrationFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct ImportedCalibration {
  CameraModel camera;  // ha2016-d2u; principal point from the file
  // "dfsm-json" | "dfsm-yaml" | "ros-camera-info" | "opencv-yaml" | "opencv-xml" |
  // "opencv-json"; empty from FitOpenCvCalibration.
  std::string format;
  // Error of fitting the file's model to ha2016-d2u over the image, in
  // pixels; 0 when the file holds native coefficients.
  double fit_max_error_px = 0.0;
  double fit_rms_error_px = 0.0;
  std::vector<std::string> notes;  // facts a user should see (fx != fy, tangential terms)
  // The file's own lens where the fit misses it by kMinResampledFitErrorPx or
  // more: the pipeline resamples the frames from it onto `camera`
  // (KnownCalibration::lens).
  std::optional<OpenCvLens> lens;
};

// Below this largest fit error a pixel's misplacement is under the tracker's
// own noise, and resampling would only blur the frames.
inline constexpr double kMinResampledFitErrorPx = 0.1;

// Reads a calibration file; the syntax is recognised from the content, not the
// name. dfsm's own files give their native coefficients unchanged. Files that
// name an image size must name width x height, the burst's size; when the file
// names none that size is used. width/height <= 0 means "unknown": the file
// must then name it.
ImportedCalibration ReadCalibrationFile(const std::filesystem::path& path, int width, int height);

// Fits ha2016-d2u (f = (fx + fy) / 2, the given principal point) to OpenCV's
// model with `distortion` = k1 k2 p1 p2 [k3 [k4 k5 k6]] (or empty) over a dense
// grid of the width x height image, by linear least squares in pixels.
ImportedCalibration FitOpenCvCalibration(int width, int height, double fx, double fy, double cx,
                                         double cy, const std::vector<double>& distortion);

}  // namespace dfsm
