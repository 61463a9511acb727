// The whole method on the real handheld clip (../shared/data/flower, no ground
// truth): it must produce a depth map whose flower heads, in front of the
// plant, come out nearer than the grass and leaves behind them.
#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "core/pipeline/pipeline.h"
#include "tests/test_data.h"

namespace dfsm {
namespace {

// Median of the valid depths inside `box`, and how many there are.
double MedianDepth(const cv::Mat& depth, const cv::Rect& box, int* count) {
  std::vector<float> values;
  for (int v = box.y; v < box.y + box.height; ++v)
    for (int u = box.x; u < box.x + box.width; ++u)
      if (depth.at<float>(v, u) > 0.0f) values.push_back(depth.at<float>(v, u));
  *count = static_cast<int>(values.size());
  if (values.empty()) return 0.0;
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

TEST(FlowerPipeline, FlowerHeadsAreNearerThanTheBackground) {
  DFSM_REQUIRE_SHARED_DATA("flower");
  const Burst burst = ReadBurst(testing::SharedData("flower"));
  const PipelineOutput output = RunPipeline(burst, {});
  ASSERT_TRUE(output.result.ok) << output.result.error;
  ASSERT_TRUE(output.dense.has_value());
  const cv::Mat& depth = output.dense->depth;
  ASSERT_EQ(depth.size(), cv::Size(512, 288));
  // Measured 0.866: the pixels along the outlines of the flower heads get no
  // depth (depth discontinuities), the relief of the heads keeps its depth.
  EXPECT_GT(output.dense->valid_fraction, 0.8);

  // Regions read off the reference frame (512x288): the large flower head at
  // the right edge, the one in the centre, and grass/leaves at the left.
  int right_count = 0, centre_count = 0, background_count = 0;
  const double right = MedianDepth(depth, cv::Rect(400, 20, 100, 160), &right_count);
  const double centre = MedianDepth(depth, cv::Rect(170, 60, 130, 140), &centre_count);
  const double background = MedianDepth(depth, cv::Rect(0, 150, 120, 130), &background_count);
  ASSERT_GT(right_count, 500);
  ASSERT_GT(centre_count, 500);
  ASSERT_GT(background_count, 500);
  EXPECT_LT(right, centre);
  EXPECT_LT(centre, background);
  EXPECT_LT(right, 0.8 * background);
}

}  // namespace
}  // namespace dfsm
