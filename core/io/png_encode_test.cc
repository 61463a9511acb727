#include "core/io/png_encode.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

namespace dfsm {
namespace {

cv::Mat NoiseOfType(int type) {
  cv::Mat image(37, 53, type);  // odd sizes: no row padding assumed
  cv::RNG rng(11);
  rng.fill(image, cv::RNG::UNIFORM, 0, image.depth() == CV_16U ? 65536 : 256);
  return image;
}

void ExpectRoundTrip(const cv::Mat& image, PngCompression compression) {
  const std::vector<unsigned char> png = EncodePng(image, compression);
  const cv::Mat decoded = cv::imdecode(png, cv::IMREAD_UNCHANGED);
  ASSERT_EQ(decoded.type(), image.type());
  ASSERT_EQ(decoded.size(), image.size());
  EXPECT_EQ(cv::norm(decoded, image, cv::NORM_INF), 0.0);
}

TEST(PngEncode, BothCompressionsAreLosslessForEveryFrameType) {
  for (int type : {CV_8UC1, CV_8UC3, CV_16UC1, CV_16UC3}) {
    SCOPED_TRACE(type);
    ExpectRoundTrip(NoiseOfType(type), PngCompression::kCompact);
    ExpectRoundTrip(NoiseOfType(type), PngCompression::kStored);
  }
}

TEST(PngEncode, StoredIsTheRawRowsWithALittleFraming) {
  // Stored blocks: each row is its filter byte and its samples, so the file
  // is the raw size plus headers, whatever the content; a flat image that
  // compresses to almost nothing is still stored at full size.
  const cv::Mat flat(480, 640, CV_8UC3, cv::Scalar(40, 80, 120));
  const size_t raw = 480 * (640 * 3 + 1);
  const size_t stored = EncodePng(flat, PngCompression::kStored).size();
  EXPECT_GE(stored, raw);
  EXPECT_LT(stored, raw + raw / 100);
  EXPECT_LT(EncodePng(flat, PngCompression::kCompact).size(), raw / 50);
}

TEST(PngEncode, RefusesWhatPngCannotHold) {
  EXPECT_THROW(EncodePng(cv::Mat(), PngCompression::kStored), std::runtime_error);
  EXPECT_THROW(EncodePng(cv::Mat(4, 4, CV_32FC1), PngCompression::kStored), std::runtime_error);
  EXPECT_THROW(EncodePng(cv::Mat(4, 4, CV_8UC2), PngCompression::kCompact), std::runtime_error);
}

}  // namespace
}  // namespace dfsm
