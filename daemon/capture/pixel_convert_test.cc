#include "daemon/capture/pixel_convert.h"

#include <gtest/gtest.h>
#include <linux/videodev2.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace dfsm::capture {
namespace {

cv::Mat TestImage(int w, int h) {
  cv::Mat bgr(h, w, CV_8UC3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      bgr.at<cv::Vec3b>(y, x) = cv::Vec3b(static_cast<uint8_t>(x * 3), static_cast<uint8_t>(y * 5),
                                          static_cast<uint8_t>((x + y) * 2));
  return bgr;
}

TEST(PixelConvert, YuyvAndUyvyTakeLumaFromEveryOtherByte) {
  const int w = 8, h = 4, stride = 2 * w + 6;
  std::vector<uint8_t> yuyv(static_cast<size_t>(stride * h), 0xee), uyvy = yuyv;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      yuyv[y * stride + 2 * x] = static_cast<uint8_t>(10 * y + x);
      yuyv[y * stride + 2 * x + 1] = 128;
      uyvy[y * stride + 2 * x + 1] = static_cast<uint8_t>(10 * y + x);
      uyvy[y * stride + 2 * x] = 128;
    }
  for (uint32_t fourcc : {V4L2_PIX_FMT_YUYV, V4L2_PIX_FMT_UYVY}) {
    const auto& data = fourcc == V4L2_PIX_FMT_YUYV ? yuyv : uyvy;
    cv::Mat gray, color;
    ConvertFrame(data.data(), data.size(), {fourcc, w, h, stride, data.size()}, gray, &color,
                 nullptr);
    ASSERT_EQ(gray.size(), cv::Size(w, h));
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) EXPECT_EQ(gray.at<uint8_t>(y, x), 10 * y + x);
    ASSERT_EQ(color.type(), CV_8UC3);
    // Neutral chroma: B = G = R = Y (BT.601 limited-range aside, within rounding).
    const cv::Vec3b p = color.at<cv::Vec3b>(2, 3);
    EXPECT_NEAR(p[0], p[2], 2);
  }
}

TEST(PixelConvert, Nv12AndYu12UseTheFirstPlaneWithItsStride) {
  const int w = 16, h = 8;
  for (int stride : {16, 20}) {
    for (uint32_t fourcc : {V4L2_PIX_FMT_NV12, V4L2_PIX_FMT_YUV420}) {
      FrameLayout layout{fourcc, w, h, stride, 0};
      layout.sizeimage = MinimumFrameBytes(layout);
      std::vector<uint8_t> data(layout.sizeimage, 128);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) data[y * stride + x] = static_cast<uint8_t>(y * 16 + x);
      cv::Mat gray, color;
      ConvertFrame(data.data(), data.size(), layout, gray, &color, nullptr);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) ASSERT_EQ(gray.at<uint8_t>(y, x), y * 16 + x);
      EXPECT_EQ(color.size(), cv::Size(w, h));
      const cv::Vec3b p = color.at<cv::Vec3b>(5, 5);
      EXPECT_NEAR(p[0], p[1], 2) << "stride " << stride;
    }
  }
}

TEST(PixelConvert, PackedRgbAndBgrWithPaddedRows) {
  const cv::Mat bgr = TestImage(10, 6);
  cv::Mat expected_gray;
  cv::cvtColor(bgr, expected_gray, cv::COLOR_BGR2GRAY);
  for (uint32_t fourcc : {V4L2_PIX_FMT_BGR24, V4L2_PIX_FMT_RGB24}) {
    const int stride = 3 * 10 + 4;
    std::vector<uint8_t> data(static_cast<size_t>(stride * 6), 0);
    for (int y = 0; y < 6; ++y)
      for (int x = 0; x < 10; ++x)
        for (int c = 0; c < 3; ++c)
          data[y * stride + 3 * x + c] =
              bgr.at<cv::Vec3b>(y, x)[fourcc == V4L2_PIX_FMT_BGR24 ? c : 2 - c];
    cv::Mat gray, color;
    ConvertFrame(data.data(), data.size(), {fourcc, 10, 6, stride, data.size()}, gray, &color,
                 nullptr);
    EXPECT_EQ(cv::norm(color, bgr, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(gray, expected_gray, cv::NORM_INF), 0.0);
  }
}

TEST(PixelConvert, ShortFramesAndNarrowRowsAreErrors) {
  std::vector<uint8_t> data(100);
  cv::Mat gray;
  EXPECT_THROW(ConvertFrame(data.data(), data.size(), {V4L2_PIX_FMT_GREY, 16, 16, 16, 256}, gray,
                            nullptr, nullptr),
               std::runtime_error);
  EXPECT_THROW(MinimumFrameBytes({V4L2_PIX_FMT_YUYV, 16, 16, 20, 0}), std::runtime_error);
  // Odd sizes of subsampled formats (fuzz/regressions/frame_convert/yu12-odd-width-overread).
  EXPECT_THROW(MinimumFrameBytes({V4L2_PIX_FMT_YUV420, 15, 2, 15, 0}), std::runtime_error);
  EXPECT_THROW(MinimumFrameBytes({V4L2_PIX_FMT_NV12, 16, 3, 16, 0}), std::runtime_error);
  EXPECT_THROW(MinimumFrameBytes({V4L2_PIX_FMT_UYVY, 7, 4, 14, 0}), std::runtime_error);
}

// Strips the DHT segments, as many webcams send their MJPEG frames.
std::vector<uint8_t> WithoutHuffmanTables(const std::vector<uint8_t>& jpeg) {
  std::vector<uint8_t> out(jpeg.begin(), jpeg.begin() + 2);
  size_t i = 2;
  while (i + 4 <= jpeg.size()) {
    const size_t length = (static_cast<size_t>(jpeg[i + 2]) << 8) | jpeg[i + 3];
    if (jpeg[i + 1] == 0xDA) {  // start of scan: the rest is entropy-coded data
      out.insert(out.end(), jpeg.begin() + static_cast<long>(i), jpeg.end());
      break;
    }
    if (jpeg[i + 1] != 0xC4)
      out.insert(out.end(), jpeg.begin() + static_cast<long>(i),
                 jpeg.begin() + static_cast<long>(i + 2 + length));
    i += 2 + length;
  }
  return out;
}

TEST(PixelConvert, MjpegDecodesToGrayWithAndWithoutHuffmanTables) {
  const cv::Mat bgr = TestImage(64, 48);
  std::vector<uint8_t> jpeg;
  ASSERT_TRUE(cv::imencode(".jpg", bgr, jpeg, {cv::IMWRITE_JPEG_QUALITY, 95}));
  const std::vector<uint8_t> bare = WithoutHuffmanTables(jpeg);
  ASSERT_LT(bare.size(), jpeg.size());
  MjpegDecoder decoder;
  const FrameLayout layout{V4L2_PIX_FMT_MJPEG, 64, 48, 0, 64 * 48 * 2};
  cv::Mat with_dht, without_dht, color;
  ConvertFrame(jpeg.data(), jpeg.size(), layout, with_dht, nullptr, &decoder);
  ConvertFrame(bare.data(), bare.size(), layout, without_dht, nullptr, &decoder);
  EXPECT_EQ(cv::norm(with_dht, without_dht, cv::NORM_INF), 0.0);
  cv::Mat expected;
  cv::cvtColor(bgr, expected, cv::COLOR_BGR2GRAY);
  EXPECT_LT(cv::norm(with_dht, expected, cv::NORM_L1) / expected.total(), 3.0);
  ConvertFrame(jpeg.data(), jpeg.size(), layout, with_dht, &color, &decoder);
  EXPECT_EQ(color.type(), CV_8UC3);

  const FrameLayout wrong{V4L2_PIX_FMT_MJPEG, 32, 48, 0, 0};
  EXPECT_THROW(ConvertFrame(jpeg.data(), jpeg.size(), wrong, with_dht, nullptr, &decoder),
               std::runtime_error);
  std::vector<uint8_t> garbage(500, 0x55);
  EXPECT_THROW(ConvertFrame(garbage.data(), garbage.size(), layout, with_dht, nullptr, &decoder),
               std::runtime_error);
}

}  // namespace
}  // namespace dfsm::capture
