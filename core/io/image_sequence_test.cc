#include "core/io/image_sequence.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "core/io/file_util.h"
#include "core/io/png_encode.h"

namespace dfsm {
namespace {
namespace fs = std::filesystem;

class ImageSequence : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("dfsm_image_sequence_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // A colour frame of noise, different for every `seed`.
  static cv::Mat Frame(int seed, int width = 64, int height = 48) {
    cv::Mat frame(height, width, CV_8UC3);
    cv::RNG rng(seed);
    rng.fill(frame, cv::RNG::UNIFORM, 0, 256);
    return frame;
  }
  void Write(const std::string& name, const cv::Mat& frame) {
    WriteFileAtomically(dir_ / name, EncodePng(frame, PngCompression::kCompact));
  }

  fs::path dir_;
};

// The same frames as a burst directory and as a folder of images: the same
// burst for the pipeline.
TEST_F(ImageSequence, AFolderReadsAsTheBurstOfTheSameFrames) {
  std::vector<cv::Mat> frames;
  for (int i = 0; i < 5; ++i) frames.push_back(Frame(i));
  BurstManifest manifest;
  WriteBurst(dir_ / "burst", manifest, frames);
  const Burst burst = ReadBurst(dir_ / "burst");
  ASSERT_TRUE(IsImageSequence((dir_ / "burst" / "frames").string()));
  EXPECT_FALSE(IsImageSequence((dir_ / "burst").string()));
  const Burst images = ReadImageSequence((dir_ / "burst" / "frames").string(), {});
  ASSERT_EQ(images.size(), burst.size());
  EXPECT_EQ(images.reference(), burst.reference());
  EXPECT_EQ(images.width(), 64);
  EXPECT_EQ(images.height(), 48);
  for (int i = 0; i < burst.size(); ++i)
    EXPECT_EQ(cv::norm(images.gray[i], burst.gray[i], cv::NORM_INF), 0.0) << i;
  EXPECT_EQ(cv::norm(images.reference_color, burst.reference_color, cv::NORM_INF), 0.0);
  for (int i = 1; i < images.size(); ++i)
    EXPECT_GT(images.manifest.frames[i].timestamp_ns, images.manifest.frames[i - 1].timestamp_ns);
}

TEST_F(ImageSequence, NamesAreOrderedWithTheirNumbersAsNumbers) {
  for (const char* name : {"f10.png", "f2.png", "f1.png", "f002b.png", "notes.txt"})
    Write(name, Frame(1));
  std::vector<std::string> names;
  for (const fs::path& image : ListImageSequence(dir_.string()))
    names.push_back(image.filename().string());
  EXPECT_EQ(names, (std::vector<std::string>{"f1.png", "f2.png", "f002b.png", "f10.png"}));
}

TEST_F(ImageSequence, AGlobPicksItsImagesAndStartAndFramesCutThem) {
  for (int i = 0; i < 6; ++i) Write("a" + std::to_string(i) + ".png", Frame(i));
  Write("b0.png", Frame(10, 32, 24));
  const std::string glob = (dir_ / "a*.png").string();
  ASSERT_TRUE(IsImageSequence(glob));
  EXPECT_EQ(ListImageSequence(glob).size(), 6u);
  ImageSequenceOptions options;
  options.start = 2;
  options.frames = 3;
  const Burst burst = ReadImageSequence(glob, options);
  ASSERT_EQ(burst.size(), 3);
  EXPECT_EQ(burst.manifest.frames.front().file, "a2.png");
  EXPECT_EQ(burst.manifest.frames.back().file, "a4.png");
}

TEST_F(ImageSequence, BadInputIsNamed) {
  const auto error = [](const std::string& input, ImageSequenceOptions options = {}) {
    try {
      ReadImageSequence(input, options);
    } catch (const BurstError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error(dir_.string()).find("names no PNG or JPEG images"), std::string::npos);
  for (int i = 0; i < 3; ++i) Write("a" + std::to_string(i) + ".png", Frame(i));
  Write("a3.png", Frame(3, 32, 24));
  EXPECT_NE(error(dir_.string()).find("'a3.png': frame is 32x24, the first image is 64x48"),
            std::string::npos)
      << error(dir_.string());
  ImageSequenceOptions late;
  late.start = 2;
  EXPECT_NE(
      error(dir_.string(), late).find("has 4 images (2 from image 2 on); a burst needs at least 3"),
      std::string::npos)
      << error(dir_.string(), late);
  Write("a0.png", Frame(0));
  WriteFileAtomically(dir_ / "a1.png", std::string("not a png"));
  EXPECT_NE(error(dir_.string()).find("'a1.png'"), std::string::npos) << error(dir_.string());
  EXPECT_NE(error((dir_ / "missing").string()).find("is not a directory of images"),
            std::string::npos);
}

}  // namespace
}  // namespace dfsm
