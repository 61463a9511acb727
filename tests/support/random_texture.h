// A test image for the trackers: uniform noise on a grid of 4 px cells,
// upsampled cubically and blurred, so every window has texture at the scale
// KLT and the gain-and-bias aligner see.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace dfsm {

inline cv::Mat RandomTexture(int width, int height, uint64_t seed, double blur_sigma_px) {
  cv::Mat noise(height / 4, width / 4, CV_8UC1);
  cv::RNG(seed).fill(noise, cv::RNG::UNIFORM, 0, 256);
  cv::Mat texture;
  cv::resize(noise, texture, cv::Size(width, height), 0, 0, cv::INTER_CUBIC);
  cv::GaussianBlur(texture, texture, cv::Size(0, 0), blur_sigma_px);
  return texture;
}

}  // namespace dfsm
