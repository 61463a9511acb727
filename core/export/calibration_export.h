// The calibration as other tools read it: calibration.json (ROS CameraInfo
// style plus the native ha2016-d2u coefficients) and calibration.yaml
// (cv::FileStorage, OpenCV's U->D distortion model).
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/camera/camera_model.h"
#include "core/io/file_util.h"

namespace dfsm {

// OpenCV's model runs the other way (undistorted -> distorted):
//   x_d = x_u (1 + c1 r_u^2 + c2 r_u^4 + c3 r_u^6).
// The fit samples the whole captured image and solves for c1..c3 by linear
// least squares; its worst error, in captured pixels, is reported beside it.
struct OpenCvDistortionFit {
  double k1 = 0.0, k2 = 0.0, k3 = 0.0;  // OpenCV's order is [k1, k2, p1, p2, k3]
  double max_error_px = 0.0;
  double rms_error_px = 0.0;
};

OpenCvDistortionFit FitOpenCvDistortion(const CameraModel& camera);

// Writes calibration.json and calibration.yaml atomically (file_util.h:
// `flush`) into out_dir and returns a summary for result.json (files, fit error).
nlohmann::json WriteCalibrationFiles(const std::filesystem::path& out_dir,
                                     const CameraModel& camera, Flush flush = Flush::kEach);

}  // namespace dfsm
