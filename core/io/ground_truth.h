// Ground truth carried beside a synthetic burst (CONTRACT.md section 2):
// BURST/ground_truth.json and the float32 depth of the reference frame.
#pragma once

#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "core/camera/camera_model.h"
#include "core/camera/pose.h"

namespace dfsm {

struct GroundTruth {
  CameraModel camera;
  std::vector<Pose> poses;  // one per frame, in manifest order
  std::string depth_file = "depth_gt.tiff";
  cv::Mat depth;  // CV_32FC1, width x height, 0 = no surface
};

bool HasGroundTruth(const std::filesystem::path& burst_dir);
// Throws std::runtime_error naming the file and field.
GroundTruth ReadGroundTruth(const std::filesystem::path& burst_dir);
void WriteGroundTruth(const std::filesystem::path& burst_dir, const GroundTruth& truth);

}  // namespace dfsm
