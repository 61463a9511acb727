#include "daemon/capture/pixel_convert.h"

#include <linux/videodev2.h>

#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

namespace dfsm::capture {

bool IsSupportedFourcc(uint32_t fourcc) {
  switch (fourcc) {
    case V4L2_PIX_FMT_YUYV:
    case V4L2_PIX_FMT_UYVY:
    case V4L2_PIX_FMT_NV12:
    case V4L2_PIX_FMT_YUV420:
    case V4L2_PIX_FMT_GREY:
    case V4L2_PIX_FMT_RGB24:
    case V4L2_PIX_FMT_BGR24:
    case V4L2_PIX_FMT_MJPEG:
    case V4L2_PIX_FMT_JPEG:
      return true;
    default:
      return false;
  }
}

bool HasCheapColor(uint32_t fourcc) {
  return fourcc == V4L2_PIX_FMT_YUYV || fourcc == V4L2_PIX_FMT_UYVY ||
         fourcc == V4L2_PIX_FMT_NV12 || fourcc == V4L2_PIX_FMT_YUV420 ||
         fourcc == V4L2_PIX_FMT_RGB24 || fourcc == V4L2_PIX_FMT_BGR24;
}

size_t MinimumFrameBytes(const FrameLayout& layout) {
  const size_t w = static_cast<size_t>(layout.width), h = static_cast<size_t>(layout.height);
  const size_t stride = static_cast<size_t>(layout.bytesperline);
  size_t row = 0;
  switch (layout.fourcc) {
    case V4L2_PIX_FMT_YUYV:
    case V4L2_PIX_FMT_UYVY:
      row = 2 * w;
      break;
    case V4L2_PIX_FMT_RGB24:
    case V4L2_PIX_FMT_BGR24:
      row = 3 * w;
      break;
    case V4L2_PIX_FMT_NV12:
    case V4L2_PIX_FMT_YUV420:
    case V4L2_PIX_FMT_GREY:
      row = w;
      break;
    default:
      return 1;  // compressed
  }
  // 4:2:2 and 4:2:0 share one chroma sample between 2 columns (and 4:2:0
  // between 2 rows): such frames exist in even sizes only, and every chroma
  // conversion below (ours and OpenCV's) reads whole samples, so an odd size
  // would read past the end of the frame. Found by fuzz/frame_convert_fuzzer.
  const bool yuv420 = layout.fourcc == V4L2_PIX_FMT_NV12 || layout.fourcc == V4L2_PIX_FMT_YUV420;
  const bool subsampled =
      yuv420 || layout.fourcc == V4L2_PIX_FMT_YUYV || layout.fourcc == V4L2_PIX_FMT_UYVY;
  if ((subsampled && w % 2 != 0) || (yuv420 && h % 2 != 0))
    throw std::runtime_error(std::string(yuv420 ? "4:2:0 frames need an even width and height"
                                                : "4:2:2 frames need an even width") +
                             ", got " + std::to_string(w) + "x" + std::to_string(h));
  if (stride < row)
    throw std::runtime_error("bytesperline " + std::to_string(stride) + " is less than the " +
                             std::to_string(row) + " bytes a row of width " + std::to_string(w) +
                             " needs");
  switch (layout.fourcc) {
    case V4L2_PIX_FMT_NV12:
      return stride * h + stride * ((h + 1) / 2);
    case V4L2_PIX_FMT_YUV420:
      return stride * h + 2 * (stride / 2) * ((h + 1) / 2);
    default:
      return stride * h;
  }
}

namespace {

// Luma of packed 4:2:2 is every other byte (offset 0 for YUYV, 1 for UYVY).
// OpenCV's universal intrinsics compile to SSE2 on x86-64 and NEON on ARM64
// (a two-way deinterleaving load); cv::extractChannel is a scalar loop.
void ExtractPackedLuma(const uint8_t* data, size_t stride, int width, int height, int offset,
                       cv::Mat& gray) {
  gray.create(height, width, CV_8UC1);
  for (int y = 0; y < height; ++y) {
    const uint8_t* src = data + stride * static_cast<size_t>(y);
    uint8_t* dst = gray.ptr<uint8_t>(y);
    int x = 0;
#if CV_SIMD
    constexpr int kLanes = cv::v_uint8::nlanes;
    for (; x + kLanes <= width; x += kLanes) {
      cv::v_uint8 even, odd;
      cv::v_load_deinterleave(src + 2 * x, even, odd);
      cv::v_store(dst + x, offset == 0 ? even : odd);
    }
#endif
    for (; x < width; ++x) dst[x] = src[2 * x + offset];
  }
}

void CheckSize(size_t bytesused, const FrameLayout& layout) {
  const size_t needed = MinimumFrameBytes(layout);
  if (bytesused < needed)
    throw std::runtime_error("short frame: " + std::to_string(bytesused) + " bytes where " +
                             std::to_string(needed) + " are needed");
}

}  // namespace

void ConvertFrame(const uint8_t* data, size_t bytesused, const FrameLayout& layout, cv::Mat& gray,
                  cv::Mat* color, MjpegDecoder* mjpeg) {
  const int w = layout.width, h = layout.height;
  const size_t stride = static_cast<size_t>(layout.bytesperline);
  auto* bytes = const_cast<uint8_t*>(data);  // cv::Mat headers; nothing writes through them
  switch (layout.fourcc) {
    case V4L2_PIX_FMT_YUYV:
    case V4L2_PIX_FMT_UYVY: {
      CheckSize(bytesused, layout);
      const bool yuyv = layout.fourcc == V4L2_PIX_FMT_YUYV;
      ExtractPackedLuma(data, stride, w, h, yuyv ? 0 : 1, gray);
      if (color != nullptr) {
        const cv::Mat packed(h, w, CV_8UC2, bytes, stride);
        cv::cvtColor(packed, *color, yuyv ? cv::COLOR_YUV2BGR_YUYV : cv::COLOR_YUV2BGR_UYVY);
      }
      return;
    }
    case V4L2_PIX_FMT_NV12: {
      CheckSize(bytesused, layout);
      const cv::Mat y(h, w, CV_8UC1, bytes, stride);
      y.copyTo(gray);
      if (color != nullptr) {
        const cv::Mat uv(h / 2, w / 2, CV_8UC2, bytes + stride * static_cast<size_t>(h), stride);
        cv::cvtColorTwoPlane(y, uv, *color, cv::COLOR_YUV2BGR_NV12);
      }
      return;
    }
    case V4L2_PIX_FMT_YUV420: {
      CheckSize(bytesused, layout);
      const cv::Mat y(h, w, CV_8UC1, bytes, stride);
      y.copyTo(gray);
      if (color != nullptr) {
        if (stride == static_cast<size_t>(w) && h % 2 == 0) {
          const cv::Mat i420(h * 3 / 2, w, CV_8UC1, bytes);
          cv::cvtColor(i420, *color, cv::COLOR_YUV2BGR_I420);
        } else {
          // Padded rows: upsample the chroma planes by hand (rare layout).
          const size_t cstride = stride / 2;
          const uint8_t* u = bytes + stride * static_cast<size_t>(h);
          const uint8_t* v = u + cstride * static_cast<size_t>((h + 1) / 2);
          cv::Mat yuv(h, w, CV_8UC3);
          for (int r = 0; r < h; ++r) {
            const uint8_t* yr = y.ptr<uint8_t>(r);
            const uint8_t* ur = u + cstride * static_cast<size_t>(r / 2);
            const uint8_t* vr = v + cstride * static_cast<size_t>(r / 2);
            auto* out = yuv.ptr<uint8_t>(r);
            for (int c = 0; c < w; ++c) {
              out[3 * c] = yr[c];
              out[3 * c + 1] = ur[c / 2];
              out[3 * c + 2] = vr[c / 2];
            }
          }
          cv::cvtColor(yuv, *color, cv::COLOR_YUV2BGR);
        }
      }
      return;
    }
    case V4L2_PIX_FMT_RGB24:
    case V4L2_PIX_FMT_BGR24: {
      // Packed 8-bit RGB (vimc, some USB grabbers): gray through OpenCV.
      CheckSize(bytesused, layout);
      const bool rgb = layout.fourcc == V4L2_PIX_FMT_RGB24;
      const cv::Mat packed(h, w, CV_8UC3, bytes, stride);
      cv::cvtColor(packed, gray, rgb ? cv::COLOR_RGB2GRAY : cv::COLOR_BGR2GRAY);
      if (color != nullptr) {
        if (rgb)
          cv::cvtColor(packed, *color, cv::COLOR_RGB2BGR);
        else
          packed.copyTo(*color);
      }
      return;
    }
    case V4L2_PIX_FMT_GREY: {
      CheckSize(bytesused, layout);
      cv::Mat(h, w, CV_8UC1, bytes, stride).copyTo(gray);
      if (color != nullptr) color->release();
      return;
    }
    case V4L2_PIX_FMT_MJPEG:
    case V4L2_PIX_FMT_JPEG: {
      if (mjpeg == nullptr) throw std::logic_error("ConvertFrame: MJPEG without a decoder");
      if (bytesused == 0) throw std::runtime_error("empty MJPEG frame");
      if (color != nullptr) {
        mjpeg->DecodeBgr(data, bytesused, w, h, *color);
        cv::cvtColor(*color, gray, cv::COLOR_BGR2GRAY);
      } else {
        mjpeg->DecodeGray(data, bytesused, w, h, gray);
      }
      return;
    }
    default:
      throw std::runtime_error("unsupported pixel format");
  }
}

}  // namespace dfsm::capture
