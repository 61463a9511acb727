// JPEG encoding through TurboJPEG (the live frame of the API, the compression
// of generated bursts), as OpenCV's imgcodecs would do it without loading them.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace dfsm {

// Encodes an 8-bit gray or BGR image at `quality` (1-100) with cv::imencode's
// defaults (4:2:0 chroma, the accurate DCT), to the same bytes. Throws
// std::runtime_error when it cannot.
std::vector<unsigned char> EncodeJpeg(const cv::Mat& image, int quality);

}  // namespace dfsm
