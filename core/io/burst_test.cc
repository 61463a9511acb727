#include "core/io/burst.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "core/io/file_util.h"

namespace dfsm {
namespace {
namespace fs = std::filesystem;

class BurstTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("dfsm_burst_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    std::vector<cv::Mat> frames;
    cv::RNG rng(7);
    for (int i = 0; i < 4; ++i) {
      cv::Mat frame(24, 32, CV_8UC3);
      rng.fill(frame, cv::RNG::UNIFORM, 0, 256);
      frames.push_back(frame);
    }
    frames_ = frames;
    BurstManifest manifest;
    manifest.reference = 1;
    manifest.source = {{"kind", "test"}};
    WriteBurst(dir_, manifest, frames);
  }
  void TearDown() override { fs::remove_all(dir_); }

  void RewriteManifest(const std::function<void(nlohmann::json&)>& edit) {
    nlohmann::json j = nlohmann::json::parse(ReadFileToString(dir_ / "manifest.json"));
    edit(j);
    WriteFileAtomically(dir_ / "manifest.json", j.dump());
  }

  // Reads the burst and returns the error message, failing the test if it succeeds.
  std::string ReadError() {
    try {
      ReadBurst(dir_);
    } catch (const BurstError& e) {
      return e.what();
    }
    ADD_FAILURE() << "ReadBurst accepted a bad burst";
    return "";
  }

  fs::path dir_;
  std::vector<cv::Mat> frames_;
};

TEST_F(BurstTest, RoundTripIsBitExact) {
  const Burst burst = ReadBurst(dir_);
  EXPECT_EQ(burst.width(), 32);
  EXPECT_EQ(burst.height(), 24);
  EXPECT_EQ(burst.reference(), 1);
  EXPECT_EQ(burst.manifest.pixel_format, "bgr8");
  EXPECT_EQ(burst.manifest.source["kind"], "test");
  ASSERT_EQ(burst.size(), 4);
  EXPECT_EQ(cv::norm(burst.reference_color, frames_[1], cv::NORM_INF), 0.0);
  for (int i = 0; i < 4; ++i)
    EXPECT_EQ(cv::norm(burst.gray[i], ToGray8(frames_[i]), cv::NORM_INF), 0.0);
}

TEST_F(BurstTest, StoredFramesReadBackBitExactAndServeThePipelineTheSame) {
  // dfsmd's captures are written stored (WriteBurstOptions::compression):
  // the same burst as the compact one, frame for frame.
  const fs::path stored = dir_ / "stored";
  WriteBurstOptions options;
  options.in_parallel = false;
  options.compression = PngCompression::kStored;
  BurstManifest manifest;
  manifest.reference = 1;
  WriteBurst(stored, manifest, frames_, options);
  const Burst compact = ReadBurst(dir_), read = ReadBurst(stored);
  ASSERT_EQ(read.size(), compact.size());
  EXPECT_EQ(cv::norm(read.reference_color, compact.reference_color, cv::NORM_INF), 0.0);
  for (int i = 0; i < read.size(); ++i)
    EXPECT_EQ(cv::norm(read.gray[i], compact.gray[i], cv::NORM_INF), 0.0);
  EXPECT_GE(fs::file_size(stored / "frames/000000.png"), 24u * (32 * 3 + 1));
}

TEST_F(BurstTest, MaxFramesKeepsAWindowWithTheReference) {
  ReadBurstOptions options;
  options.max_frames = 3;
  const Burst burst = ReadBurst(dir_, options);
  EXPECT_EQ(burst.size(), 3);
  EXPECT_EQ(burst.reference(), 1);
  EXPECT_EQ(cv::norm(burst.gray[1], ToGray8(frames_[1]), cv::NORM_INF), 0.0);
}

// --frames N is a window around the reference, not the N frames ending at it.
TEST_F(BurstTest, MaxFramesCentresTheWindowOnTheReference) {
  RewriteManifest([](nlohmann::json& j) { j["reference"] = 2; });
  ReadBurstOptions options;
  options.max_frames = 3;
  const Burst burst = ReadBurst(dir_, options);
  EXPECT_EQ(burst.reference(), 1);
  EXPECT_EQ(burst.frame_indices(), (std::vector<int>{1, 2, 3}));
  EXPECT_EQ(cv::norm(burst.gray[1], ToGray8(frames_[2]), cv::NORM_INF), 0.0);
  // At the end of the burst the window shifts inwards instead of shrinking.
  RewriteManifest([](nlohmann::json& j) { j["reference"] = 3; });
  const Burst last = ReadBurst(dir_, options);
  EXPECT_EQ(last.frame_indices(), (std::vector<int>{1, 2, 3}));
  EXPECT_EQ(last.reference(), 2);
  EXPECT_EQ(ReadBurst(dir_).frame_indices(), (std::vector<int>{0, 1, 2, 3}));
}

TEST_F(BurstTest, RejectsNonJson) {
  WriteFileAtomically(dir_ / "manifest.json", std::string("{not json"));
  EXPECT_NE(ReadError().find("not valid JSON"), std::string::npos);
}

// A 200 KB manifest of 100 000 nested arrays crashed dfsmd: the error message
// serialized the value with dump(), which recursed through the whole stack.
TEST_F(BurstTest, RejectsDeepNestingWithoutRecursing) {
  const int depth = 100000;
  WriteFileAtomically(dir_ / "manifest.json",
                      "{\"format\":\"dfsm-burst/1\",\"height\":480,\"frames\":[],\"width\":" +
                          std::string(depth, '[') + std::string(depth, ']') + "}");
  EXPECT_NE(ReadError().find("nested deeper than"), std::string::npos);
}

TEST_F(BurstTest, QuotesAnOffendingContainerWithoutSerializingIt) {
  RewriteManifest([](nlohmann::json& j) { j["width"] = nlohmann::json::array({1, 2, 3}); });
  const std::string error = ReadError();
  EXPECT_NE(error.find("'width' must be a positive integer (got an array of 3 elements)"),
            std::string::npos)
      << error;
}

TEST_F(BurstTest, RejectsAnotherFormat) {
  RewriteManifest([](nlohmann::json& j) { j["format"] = "dfsm-burst/9"; });
  EXPECT_NE(ReadError().find("dfsm-burst/9"), std::string::npos);
}

TEST_F(BurstTest, RejectsFewerThanThreeFrames) {
  RewriteManifest([](nlohmann::json& j) {
    j["frames"].erase(2);
    j["frames"].erase(2);
  });
  EXPECT_NE(ReadError().find("at least 3 frames"), std::string::npos);
}

TEST_F(BurstTest, RejectsAMissingFrame) {
  fs::remove(dir_ / "frames/000002.png");
  const std::string error = ReadError();
  EXPECT_NE(error.find("000002.png"), std::string::npos) << error;
  EXPECT_NE(error.find("missing"), std::string::npos) << error;
}

TEST_F(BurstTest, RejectsAnUnreadableFrame) {
  WriteFileAtomically(dir_ / "frames/000003.png", std::string("garbage"));
  EXPECT_NE(ReadError().find("unreadable"), std::string::npos);
}

TEST_F(BurstTest, RejectsATruncatedJpegAndAnEmptyFrame) {
  // JPEG frames under their PNG names (the reader goes by content): whole,
  // with bytes after the end-of-image marker (some cameras append a trailer)
  // they read; cut short (libjpeg would fill the rest with grey) they do not.
  std::vector<uchar> jpeg;
  cv::imencode(".jpg", frames_[2], jpeg);
  std::string whole(jpeg.begin(), jpeg.end());
  WriteFileAtomically(dir_ / "frames/000002.png", whole + std::string(40, '\0') + "TRAILER");
  EXPECT_EQ(ReadBurst(dir_).size(), 4);
  WriteFileAtomically(dir_ / "frames/000002.png", whole.substr(0, whole.size() * 3 / 4));
  const std::string error = ReadError();
  EXPECT_NE(error.find("frames[2] 'frames/000002.png': truncated JPEG"), std::string::npos)
      << error;
  WriteFileAtomically(dir_ / "frames/000002.png", std::string());
  EXPECT_NE(ReadError().find("000002.png': empty file"), std::string::npos);
}

TEST_F(BurstTest, RejectsAFrameOfAnotherSize) {
  cv::imwrite((dir_ / "frames/000000.png").string(), cv::Mat(10, 10, CV_8UC1, cv::Scalar(3)));
  EXPECT_NE(ReadError().find("10x10"), std::string::npos);
}

TEST_F(BurstTest, RejectsPathsOutsideTheBurst) {
  for (const std::string path : {"../escape.png", "/etc/passwd", "frames/../../x.png"}) {
    RewriteManifest([&](nlohmann::json& j) { j["frames"][0]["file"] = path; });
    EXPECT_NE(ReadError().find("outside the burst directory"), std::string::npos) << path;
  }
}

// "frames/000000.png\0.jpg" passed the containment check as "frames/000000.png"
// and was cut short in the error message: control characters are refused by
// the manifest parser, before any file system call.
TEST_F(BurstTest, RejectsControlCharactersInFrameNamesByName) {
  for (const std::string& path :
       {std::string("frames/000000.png\0.jpg", 22), std::string("frames/\n000000.png"),
        std::string("frames/000000.png\x7F")}) {
    RewriteManifest([&](nlohmann::json& j) { j["frames"][0]["file"] = path; });
    const std::string error = ReadError();
    EXPECT_NE(error.find("'file' contains the control character 0x"), std::string::npos) << error;
    EXPECT_EQ(error.find('\0'), std::string::npos);
  }
}

TEST_F(BurstTest, RejectsASymlinkLeadingOut) {
  const fs::path outside = dir_.string() + "_outside.png";
  fs::copy_file(dir_ / "frames/000000.png", outside, fs::copy_options::overwrite_existing);
  fs::create_symlink(outside, dir_ / "frames/link.png");
  RewriteManifest([](nlohmann::json& j) { j["frames"][0]["file"] = "frames/link.png"; });
  EXPECT_NE(ReadError().find("outside the burst directory"), std::string::npos);
  fs::remove(outside);
}

TEST_F(BurstTest, RejectsABadReferenceAndMissingFields) {
  RewriteManifest([](nlohmann::json& j) { j["reference"] = 9; });
  EXPECT_NE(ReadError().find("reference 9"), std::string::npos);
  RewriteManifest([](nlohmann::json& j) {
    j["reference"] = 0;
    j.erase("width");
  });
  EXPECT_NE(ReadError().find("'width'"), std::string::npos);
}

TEST_F(BurstTest, SixteenBitFramesAreScaledToEightBit) {
  cv::Mat sixteen(24, 32, CV_16UC1, cv::Scalar(257 * 100));
  cv::imwrite((dir_ / "frames/000000.png").string(), sixteen);
  const Burst burst = ReadBurst(dir_);
  EXPECT_EQ(burst.gray[0].type(), CV_8UC1);
  EXPECT_EQ(burst.gray[0].at<uchar>(5, 5), 100);
}

}  // namespace
}  // namespace dfsm
