// The sparse stage on a real handheld clip (../shared/data/flower, 31 frames,
// 512x288, no ground truth): it must succeed with a plausible camera.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "core/io/burst.h"
#include "core/sparse/sparse_reconstruction.h"
#include "tests/test_data.h"

namespace dfsm {
namespace {

TEST(FlowerSparse, ReconstructsWithAPlausibleCamera) {
  DFSM_REQUIRE_SHARED_DATA("flower");
  const Burst burst = ReadBurst(testing::SharedData("flower"));
  ASSERT_EQ(burst.size(), 31);
  for (const InitMode init : {InitMode::kRankOne, InitMode::kNaive}) {
    SparseOptions options;
    options.init = init;
    const SparseReconstruction sparse = ReconstructSparse(burst.gray, burst.reference(), options);
    const int inliers =
        static_cast<int>(std::count(sparse.inliers.begin(), sparse.inliers.end(), true));
    // 512x288 gives 25x14 cells of 21 px; a textured clip keeps most of them.
    EXPECT_GT(sparse.feature_stats.tracks, 200) << InitModeName(init);
    EXPECT_GT(inliers, 180) << InitModeName(init);
    EXPECT_TRUE(sparse.bundle_adjustment.converged) << sparse.bundle_adjustment.termination;
    EXPECT_LT(sparse.bundle_adjustment.rms_reprojection_px, 0.3);
    // A phone-class lens: horizontal field of view between 30 and 80 degrees.
    const double hfov = 2.0 * std::atan(256.0 / sparse.state.camera.f) * 180.0 / M_PI;
    EXPECT_GT(hfov, 30.0) << "f = " << sparse.state.camera.f;
    EXPECT_LT(hfov, 80.0) << "f = " << sparse.state.camera.f;
    // The clip's median track motion is about 9 px (its README).
    EXPECT_NEAR(sparse.tracks.MedianMaxDisplacement(), 9.0, 2.0);
    for (const double w : sparse.InlierInverseDepths()) EXPECT_GT(w, 0.0);
  }
}

TEST(FlowerSparse, RankOneNeedsFewerIterationsThanNaive) {
  DFSM_REQUIRE_SHARED_DATA("flower");
  const Burst burst = ReadBurst(testing::SharedData("flower"));
  SparseOptions rank1, naive;
  naive.init = InitMode::kNaive;
  const auto a = ReconstructSparse(burst.gray, burst.reference(), rank1);
  const auto b = ReconstructSparse(burst.gray, burst.reference(), naive);
  // Over every run of the adjustment (the first and the outlier rounds).
  const auto total = [](const SparseReconstruction& sparse) {
    int iterations = 0;
    for (const BundleAdjustmentRun& run : sparse.runs) iterations += run.iterations;
    return iterations;
  };
  EXPECT_LT(total(a), total(b));
  // Both reach the same camera: the rank-1 start only makes it cheaper.
  EXPECT_NEAR(a.state.camera.f, b.state.camera.f, 0.05 * a.state.camera.f);
}

TEST(FlowerSparse, AStillBurstFailsWithANamedReason) {
  DFSM_REQUIRE_SHARED_DATA("flower");
  const Burst burst = ReadBurst(testing::SharedData("flower"));
  const std::vector<cv::Mat> still(5, burst.gray[0]);
  try {
    ReconstructSparse(still, 0);
    FAIL() << "a burst without motion was reconstructed";
  } catch (const ReconstructionError& e) {
    EXPECT_NE(std::string(e.what()).find("insufficient parallax"), std::string::npos) << e.what();
  }
}

TEST(FlowerSparse, AFlatBurstFailsForLackOfTexture) {
  const std::vector<cv::Mat> flat(5, cv::Mat(288, 512, CV_8UC1, cv::Scalar(0)));
  try {
    ReconstructSparse(flat, 0);
    FAIL() << "an all-black burst was reconstructed";
  } catch (const ReconstructionError& e) {
    EXPECT_NE(std::string(e.what()).find("too few tracks"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("texture"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dfsm
