// Frame sizes read from PNG/JPEG headers, and the [limits] checks an uploaded
// burst passes before any frame is decoded.
#include "daemon/service/burst_limits.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <opencv2/imgcodecs.hpp>

#include "core/io/file_util.h"
#include "daemon/service/image_size.h"

namespace dfsm::service {
namespace {

namespace fs = std::filesystem;

std::string Encode(const std::string& extension, int width, int height) {
  std::vector<unsigned char> bytes;
  cv::imencode(extension, cv::Mat(height, width, CV_8UC1, cv::Scalar(90)), bytes);
  return std::string(bytes.begin(), bytes.end());
}

// A PNG whose IHDR claims another size (the CRC is not checked by the sniffer,
// OpenCV would decode the claim).
std::string ForgedPng(uint32_t width, uint32_t height) {
  std::string png = Encode(".png", 4, 4);
  for (int i = 0; i < 4; ++i) {
    png[16 + i] = static_cast<char>(width >> (24 - 8 * i));
    png[20 + i] = static_cast<char>(height >> (24 - 8 * i));
  }
  return png;
}

TEST(ImageSizeTest, ReadsPngAndJpegHeaders) {
  const std::optional<ImageSize> png = ReadImageSize(Encode(".png", 320, 240));
  ASSERT_TRUE(png);
  EXPECT_EQ(png->width, 320);
  EXPECT_EQ(png->height, 240);
  const std::optional<ImageSize> jpeg = ReadImageSize(Encode(".jpg", 17, 1000));
  ASSERT_TRUE(jpeg);
  EXPECT_EQ(jpeg->width, 17);
  EXPECT_EQ(jpeg->height, 1000);
  const std::optional<ImageSize> forged = ReadImageSize(ForgedPng(100000, 100000));
  ASSERT_TRUE(forged);
  EXPECT_EQ(forged->width, 100000);
}

TEST(ImageSizeTest, RejectsOtherAndTruncatedData) {
  EXPECT_FALSE(ReadImageSize(""));
  EXPECT_FALSE(ReadImageSize("not an image at all, just text"));
  EXPECT_FALSE(ReadImageSize(Encode(".png", 8, 8).substr(0, 20)));
  EXPECT_FALSE(ReadImageSize(Encode(".jpg", 8, 8).substr(0, 4)));
  EXPECT_FALSE(ReadImageSize(Encode(".bmp", 8, 8)));
  EXPECT_FALSE(ReadImageSize(std::string("\xff\xd8\xff\xe0\x00\x01", 6)));  // bad length
}

class BurstLimitsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("burst-limits-test-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "frames");
    manifest_.width = 32;
    manifest_.height = 24;
    for (int i = 0; i < 4; ++i) {
      const std::string file = "frames/" + std::to_string(i) + ".png";
      WriteFileAtomically(dir_ / file, Encode(".png", 32, 24));
      manifest_.frames.push_back({file, i, i});
    }
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string ErrorOf(int requested = 0) {
    try {
      CheckUploadedBurst(dir_, manifest_, requested, limits_);
    } catch (const BurstError& e) {
      return e.what();
    }
    return "";
  }

  fs::path dir_;
  BurstManifest manifest_;
  BurstLimits limits_;
};

TEST_F(BurstLimitsTest, AcceptsABurstWithinTheLimits) { EXPECT_EQ(ErrorOf(), ""); }

TEST_F(BurstLimitsTest, NamesTheExceededLimit) {
  limits_.max_frames = 3;
  EXPECT_EQ(ErrorOf(), "manifest.json: 4 frames exceed limits.max_burst_frames (3)");
  limits_ = {};
  limits_.max_frame_pixels = 32 * 24 - 1;
  EXPECT_EQ(ErrorOf(), "manifest.json: 32x24 frames exceed limits.max_frame_pixels (767 pixels)");
  limits_ = {};
  limits_.max_burst_pixels = 3 * 32 * 24;
  EXPECT_NE(ErrorOf().find("4 frames of 32x24 are 3072 pixels, over limits.max_burst_pixels "
                           "(2304)"),
            std::string::npos)
      << ErrorOf();
  EXPECT_EQ(ErrorOf(3), "");  // ?frames=3 keeps three: within the limit
}

TEST_F(BurstLimitsTest, RefusesAFrameWhoseHeaderDisagreesWithTheManifest) {
  WriteFileAtomically(dir_ / "frames/2.png", ForgedPng(30000, 30000));
  EXPECT_EQ(ErrorOf(),
            "manifest.json: frames[2] 'frames/2.png': the file declares 30000x30000, the "
            "manifest says 32x24");
}

TEST_F(BurstLimitsTest, RefusesMissingForeignAndEscapingFrames) {
  WriteFileAtomically(dir_ / "frames/1.png", "GIF89a......");
  EXPECT_NE(ErrorOf().find("frames[1] 'frames/1.png': not a PNG or JPEG file"), std::string::npos);
  manifest_.frames[1].file = "frames/absent.png";
  EXPECT_NE(ErrorOf().find("frames[1] 'frames/absent.png': file is missing"), std::string::npos);
  for (const char* escape : {"../outside.png", "frames/../../outside.png", "/etc/passwd"}) {
    manifest_.frames[1].file = escape;
    EXPECT_NE(ErrorOf().find("path lies outside the burst directory"), std::string::npos) << escape;
  }
}

}  // namespace
}  // namespace dfsm::service
