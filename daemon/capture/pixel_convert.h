// Conversion of one V4L2 buffer, laid out as the driver says (fourcc,
// bytesperline, sizeimage), to the 8-bit gray the pipeline uses and, where it
// is cheap, BGR for previews. Luma is taken straight from the buffer: every
// other byte of YUYV/UYVY, the first plane of NV12/YU12, all of GREY.
#pragma once

#include <cstddef>
#include <cstdint>
#include <opencv2/core.hpp>

#include "daemon/capture/mjpeg_decoder.h"

namespace dfsm::capture {

struct FrameLayout {
  uint32_t fourcc = 0;
  int width = 0, height = 0;
  int bytesperline = 0;  // of the (first) plane
  size_t sizeimage = 0;
};

// True for the fourccs ConvertFrame understands.
bool IsSupportedFourcc(uint32_t fourcc);
// Whether the format carries colour that ConvertFrame can keep cheaply.
bool HasCheapColor(uint32_t fourcc);

// The smallest number of bytes a frame of this layout fills (for compressed
// formats: 1). Throws std::runtime_error when bytesperline is too small for the width,
// or the size is odd where the chroma subsampling needs it even (4:2:2 width, 4:2:0 both).
size_t MinimumFrameBytes(const FrameLayout& layout);

// Converts `bytesused` bytes at `data`. `gray` is always written; `color` is
// written when non-null and the format has colour (else released). Buffers
// are reused when they have the right size. `mjpeg` is needed for MJPG.
// Throws std::runtime_error for a short or corrupt frame.
void ConvertFrame(const uint8_t* data, size_t bytesused, const FrameLayout& layout, cv::Mat& gray,
                  cv::Mat* color, MjpegDecoder* mjpeg);

}  // namespace dfsm::capture
