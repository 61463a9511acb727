// Fuzzes the conversion of camera buffers to the pipeline's 8-bit gray
// (daemon/capture/pixel_convert.h), MJPEG included (TurboJPEG through
// daemon/capture/mjpeg_decoder.h). A buffer is whatever a driver hands over:
// its size and contents are untrusted, its layout is what was negotiated.
//
// Input: 5 layout bytes, then the buffer.
//   [0] format: index into kFourccs   [1] width - 1   [2] height - 1
//   [3] bytesperline padding (bit 7: a stride 1 byte too short for the width)
//   [4] bit 0: also convert to colour
// Sizes stay below 257 x 257 so that every input runs fast.
#include <linux/videodev2.h>

#include <cstddef>
#include <cstdint>
#include <stdexcept>

#include "daemon/capture/mjpeg_decoder.h"
#include "daemon/capture/pixel_convert.h"
#include "fuzz/fuzz_check.h"

namespace {

using namespace dfsm::capture;

constexpr uint32_t kFourccs[] = {V4L2_PIX_FMT_YUYV,   V4L2_PIX_FMT_UYVY,  V4L2_PIX_FMT_NV12,
                                 V4L2_PIX_FMT_YUV420, V4L2_PIX_FMT_GREY,  V4L2_PIX_FMT_RGB24,
                                 V4L2_PIX_FMT_BGR24,  V4L2_PIX_FMT_MJPEG, V4L2_PIX_FMT_JPEG,
                                 V4L2_PIX_FMT_H264};  // the last one is unsupported
constexpr size_t kHeader = 5;

int BytesPerPixel(uint32_t fourcc) {
  switch (fourcc) {
    case V4L2_PIX_FMT_YUYV:
    case V4L2_PIX_FMT_UYVY:
      return 2;
    case V4L2_PIX_FMT_RGB24:
    case V4L2_PIX_FMT_BGR24:
      return 3;
    default:
      return 1;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < kHeader) return 0;
  static MjpegDecoder decoder;
  FrameLayout layout;
  layout.fourcc = kFourccs[data[0] % (sizeof(kFourccs) / sizeof(kFourccs[0]))];
  layout.width = 1 + data[1];
  layout.height = 1 + data[2];
  const int row = layout.width * BytesPerPixel(layout.fourcc);
  layout.bytesperline = (data[3] & 0x80) ? row - 1 : row + (data[3] & 0x7f);
  const bool want_color = data[4] & 1;
  const uint8_t* buffer = data + kHeader;
  const size_t bytesused = size - kHeader;
  layout.sizeimage = bytesused;

  cv::Mat gray, color;
  try {
    ConvertFrame(buffer, bytesused, layout, gray, want_color ? &color : nullptr, &decoder);
  } catch (const std::runtime_error& error) {
    dfsm::fuzz::CheckNamedError(error);
    return 0;
  }
  FUZZ_CHECK(IsSupportedFourcc(layout.fourcc), "converted an unsupported format");
  FUZZ_CHECK(gray.type() == CV_8UC1 && gray.cols == layout.width && gray.rows == layout.height,
             "gray frame of the wrong size or type");
  if (want_color && !color.empty()) {
    FUZZ_CHECK(color.type() == CV_8UC3 && color.cols == layout.width && color.rows == layout.height,
               "colour frame of the wrong size or type");
  }
  return 0;
}
