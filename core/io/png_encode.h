// PNG encoding at two speeds. Frames and outputs are PNG everywhere
// (CONTRACT.md); what differs is how much CPU their encoding may take.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace dfsm {

enum class PngCompression {
  // zlib's RLE strategy at level 1 with the Sub filter (OpenCV's defaults,
  // the fastest of its settings measured): ~70 ms for a 1080p colour frame,
  // about 2/3 of the raw size for a photograph. For files that are kept.
  kCompact,
  // No filter, deflate's stored blocks: the raw pixels framed as a PNG any
  // reader decodes. ~12 ms for a 1080p colour frame (6.2 MB). For files
  // written beside a running pipeline, whose CPU they would otherwise take.
  kStored,
};

// Encodes an 8- or 16-bit image of 1 or 3 channels (BGR) as PNG. Throws
// std::runtime_error when it cannot.
std::vector<unsigned char> EncodePng(const cv::Mat& image, PngCompression compression);

}  // namespace dfsm
