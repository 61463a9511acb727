#include "core/io/depth_tiff.h"

#include <gtest/gtest.h>
#include <tiffio.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

namespace dfsm {
namespace {

namespace fs = std::filesystem;

class DepthTiffTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("dfsm_depth_tiff_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  static cv::Mat Depth(int rows, int cols) {
    cv::Mat depth(rows, cols, CV_32FC1);
    cv::RNG rng(3);
    rng.fill(depth, cv::RNG::UNIFORM, 0.5, 40.0);
    depth(cv::Rect(0, 0, cols / 3, rows / 2)).setTo(0.0f);  // no estimate
    return depth;
  }

  fs::path dir_;
};

void ExpectIdentical(const cv::Mat& a, const cv::Mat& b) {
  ASSERT_EQ(a.type(), CV_32FC1);
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
}

TEST_F(DepthTiffTest, RoundTripsEveryBitAndOtherReadersAgree) {
  const cv::Mat depth = Depth(37, 53);
  WriteDepthTiff(dir_ / "depth.tiff", depth);
  ExpectIdentical(ReadDepthTiff(dir_ / "depth.tiff"), depth);
  // OpenCV's reader (libtiff underneath, but not our code) reads the same.
  ExpectIdentical(cv::imread((dir_ / "depth.tiff").string(), cv::IMREAD_UNCHANGED), depth);
}

TEST_F(DepthTiffTest, ReadsWhatOpenCvWritesWithAnyCompression) {
  // Earlier depth.tiff and depth_gt.tiff files were written by OpenCV with
  // deflate; other tools write LZW or nothing.
  const cv::Mat depth = Depth(41, 29);
  for (const int compression : {1 /* none */, 5 /* LZW */, 8 /* deflate */}) {
    const fs::path path = dir_ / ("cv" + std::to_string(compression) + ".tiff");
    ASSERT_TRUE(cv::imwrite(path.string(), depth, {cv::IMWRITE_TIFF_COMPRESSION, compression}));
    ExpectIdentical(ReadDepthTiff(path), depth);
  }
}

TEST_F(DepthTiffTest, ReadsATiledTiff) {
  const cv::Mat depth = Depth(40, 50);  // tiles of 16 overhang both edges
  const fs::path path = dir_ / "tiled.tiff";
  TIFF* tiff = TIFFOpen(path.c_str(), "w");
  ASSERT_NE(tiff, nullptr);
  TIFFSetField(tiff, TIFFTAG_IMAGEWIDTH, 50);
  TIFFSetField(tiff, TIFFTAG_IMAGELENGTH, 40);
  TIFFSetField(tiff, TIFFTAG_BITSPERSAMPLE, 32);
  TIFFSetField(tiff, TIFFTAG_SAMPLEFORMAT, SAMPLEFORMAT_IEEEFP);
  TIFFSetField(tiff, TIFFTAG_SAMPLESPERPIXEL, 1);
  TIFFSetField(tiff, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_MINISBLACK);
  TIFFSetField(tiff, TIFFTAG_TILEWIDTH, 16);
  TIFFSetField(tiff, TIFFTAG_TILELENGTH, 16);
  TIFFSetField(tiff, TIFFTAG_COMPRESSION, COMPRESSION_ADOBE_DEFLATE);
  std::vector<float> tile(16 * 16);
  for (int y = 0; y < 40; y += 16) {
    for (int x = 0; x < 50; x += 16) {
      for (int ty = 0; ty < 16; ++ty)
        for (int tx = 0; tx < 16; ++tx)
          tile[ty * 16 + tx] = y + ty < 40 && x + tx < 50 ? depth.at<float>(y + ty, x + tx) : -1;
      ASSERT_GE(TIFFWriteTile(tiff, tile.data(), x, y, 0, 0), 0);
    }
  }
  TIFFClose(tiff);
  ExpectIdentical(ReadDepthTiff(path), depth);
}

TEST_F(DepthTiffTest, RefusesWhatIsNotAFloatDepthMapWithItsReason) {
  const auto message = [](const fs::path& path) {
    try {
      ReadDepthTiff(path);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message(dir_ / "missing.tiff").find("missing or not a TIFF image"), std::string::npos);

  const fs::path sixteen = dir_ / "sixteen.tiff";
  ASSERT_TRUE(cv::imwrite(sixteen.string(), cv::Mat(4, 4, CV_16UC1, cv::Scalar(7))));
  EXPECT_NE(message(sixteen).find("expected single-channel float32, got 1 channel(s) of 16-bit "
                                  "integer samples"),
            std::string::npos)
      << message(sixteen);

  const fs::path png = dir_ / "not.tiff";
  ASSERT_TRUE(cv::imwrite((dir_ / "x.png").string(), cv::Mat(4, 4, CV_8UC1, cv::Scalar(7))));
  fs::rename(dir_ / "x.png", png);
  EXPECT_NE(message(png).find("missing or not a TIFF image"), std::string::npos) << message(png);

  // Cut short: the header is there, the rows are not.
  WriteDepthTiff(dir_ / "whole.tiff", Depth(64, 64));
  std::string bytes;
  {
    std::ifstream in(dir_ / "whole.tiff", std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  std::ofstream(dir_ / "cut.tiff", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  EXPECT_NE(message(dir_ / "cut.tiff"), "no error");
}

TEST_F(DepthTiffTest, WriteRefusesAnythingButFloat) {
  EXPECT_THROW(WriteDepthTiff(dir_ / "x.tiff", cv::Mat(4, 4, CV_16UC1)), std::runtime_error);
}

}  // namespace
}  // namespace dfsm
