#include "core/export/depth_export.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/io/depth_tiff.h"
#include "core/io/file_util.h"

namespace dfsm {
namespace {

TEST(DepthExport, WritesEveryFileWithDocumentedScaling) {
  const auto dir = std::filesystem::temp_directory_path() / "dfsm_depth_export_test";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  cv::Mat depth(48, 64, CV_32FC1, cv::Scalar(2.0f));
  depth(cv::Rect(0, 0, 32, 48)).setTo(1.0f);
  depth.at<float>(5, 40) = 0.0f;  // no estimate
  const cv::Mat confidence(48, 64, CV_32FC1, cv::Scalar(0.5f));
  const cv::Mat colour(48, 64, CV_8UC3, cv::Scalar(10, 20, 30));
  const CameraModel camera = CameraModel::Initial(64, 48);

  const nlohmann::json summary = WriteDepthOutputs(dir, depth, confidence, colour, camera);

  EXPECT_EQ(cv::norm(ReadDepthTiff(dir / "depth.tiff"), depth, cv::NORM_INF), 0.0);
  const cv::Mat depth16 = cv::imread((dir / "depth.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(depth16.type(), CV_16UC1);
  const double scale = summary["depth_png_scale"];
  EXPECT_NEAR(depth16.at<uint16_t>(0, 0) * scale, 1.0, 1e-4);
  EXPECT_EQ(depth16.at<uint16_t>(5, 40), 0);
  EXPECT_EQ(depth16.at<uint16_t>(0, 63), 65535);

  const cv::Mat confidence8 = cv::imread((dir / "confidence.png").string(), cv::IMREAD_UNCHANGED);
  EXPECT_NEAR(confidence8.at<uchar>(3, 3), 128, 1);

  const cv::Mat preview = cv::imread((dir / "preview.png").string(), cv::IMREAD_COLOR);
  ASSERT_EQ(preview.cols, 128);
  EXPECT_EQ(preview.at<cv::Vec3b>(0, 0), cv::Vec3b(10, 20, 30));           // the reference
  EXPECT_EQ(preview.at<cv::Vec3b>(5, 64 + 40), cv::Vec3b(0, 0, 0));        // no estimate
  EXPECT_NE(preview.at<cv::Vec3b>(0, 64), preview.at<cv::Vec3b>(0, 127));  // near vs far

  EXPECT_EQ(summary["preview_scale"], 1.0);
  EXPECT_EQ(summary["points"], 64 * 48 - 1);
  const std::string ply = ReadFileToString(dir / "points.ply");
  EXPECT_NE(ply.find("element vertex 3071"), std::string::npos);
  std::filesystem::remove_all(dir);
}

TEST(DepthExport, PreviewIsScaledToItsMaximumWidthWithTheFullMapsColourRange) {
  cv::Mat depth(96, 128, CV_32FC1, cv::Scalar(2.0f));
  depth(cv::Rect(0, 0, 64, 96)).setTo(1.0f);
  depth(cv::Rect(64, 0, 32, 32)).setTo(0.0f);  // no estimate
  depth.at<float>(95, 127) = 4.0f;             // the farthest: a single pixel the preview skips
  cv::Mat colour(96, 128, CV_8UC3, cv::Scalar(10, 20, 30));
  colour(cv::Rect(0, 0, 2, 2)).setTo(cv::Scalar(90, 100, 110));

  EXPECT_DOUBLE_EQ(PreviewScale(128, 1920), 1.0);
  EXPECT_DOUBLE_EQ(PreviewScale(1920, 1920), 0.5);
  const cv::Mat preview = DepthPreview(depth, colour, 128);
  ASSERT_EQ(preview.size(), cv::Size(128, 48));
  EXPECT_EQ(preview.at<cv::Vec3b>(0, 0), cv::Vec3b(90, 100, 110));  // averaged 2x2 block
  EXPECT_EQ(preview.at<cv::Vec3b>(10, 10), cv::Vec3b(10, 20, 30));
  EXPECT_EQ(preview.at<cv::Vec3b>(5, 64 + 40), cv::Vec3b(0, 0, 0));  // no estimate stays black
  // Depth 2 is inverse depth 0.5 within [0.25, 1] of the full map, not the
  // far end of the [0.5, 1] that the subsampled map alone would give.
  cv::Mat expected;
  cv::applyColorMap(cv::Mat(1, 1, CV_8UC1, cv::Scalar(85)), expected, cv::COLORMAP_TURBO);
  EXPECT_EQ(preview.at<cv::Vec3b>(40, 64 + 60), expected.at<cv::Vec3b>(0, 0));
}

TEST(DepthExport, PointCloudLiesOnTheDepthAlongPixelRays) {
  CameraModel camera = CameraModel::Initial(64, 48);
  camera.k1 = -0.1;
  const cv::Mat depth(48, 64, CV_32FC1, cv::Scalar(3.0f));
  const cv::Mat gray(48, 64, CV_8UC1, cv::Scalar(7));
  const std::vector<ColoredPoint> points = DepthPointCloud(depth, gray, camera, 4);
  ASSERT_EQ(points.size(), 16u * 12u);
  for (const ColoredPoint& point : points) {
    EXPECT_FLOAT_EQ(point.position.z(), 3.0f);
    EXPECT_EQ(point.r, 7);
  }
}

}  // namespace
}  // namespace dfsm
