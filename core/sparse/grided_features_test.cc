#include "core/sparse/grided_features.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <functional>
#include <opencv2/imgproc.hpp>
#include <set>

#include "tests/support/random_texture.h"

namespace dfsm {
namespace {

cv::Mat Texture(int width, int height, uint64_t seed) {
  return RandomTexture(width, height, seed, 1.0);
}

cv::Mat Shift(const cv::Mat& image, double dx, double dy) {
  const cv::Mat M = (cv::Mat_<double>(2, 3) << 1, 0, dx, 0, 1, dy);
  cv::Mat shifted;
  cv::warpAffine(image, shifted, M, image.size(), cv::INTER_CUBIC, cv::BORDER_REFLECT);
  return shifted;
}

TEST(GridedFeatures, CellSizeScalesWithResolution) {
  GridedFeatureOptions options;
  EXPECT_EQ(GridCellSize(options, 1920, 1080), 80);
  EXPECT_EQ(GridCellSize(options, 640, 480), 36);
  options.cell_px = 50;
  EXPECT_EQ(GridCellSize(options, 640, 480), 50);
}

TEST(GridedFeatures, TheResponseInBandsIsOpenCVsOnTheWholeFrame) {
  // A frame of many bands, an odd one, and one lower than a band.
  for (const cv::Size size : {cv::Size(1920, 1080), cv::Size(641, 479), cv::Size(50, 7)}) {
    cv::Mat gray(size, CV_8UC1);
    cv::RNG random(3);
    random.fill(gray, cv::RNG::UNIFORM, 0, 256);
    cv::GaussianBlur(gray, gray, cv::Size(5, 5), 1.2);
    cv::Mat expected;
    cv::cornerMinEigenVal(gray, expected, 3, 3);
    const cv::Mat response = CornerResponse(gray);
    ASSERT_EQ(response.size(), size);
    cv::Mat difference;
    cv::absdiff(response, expected, difference);
    double largest = 0.0, strongest = 0.0;
    cv::minMaxLoc(difference, nullptr, &largest);
    cv::minMaxLoc(expected, nullptr, &strongest);
    // OpenCV's float box sum runs down the rows, so a band that starts
    // elsewhere rounds differently: at 1080p two responses differ, by
    // 5e-10 where the strongest is 0.019.
    EXPECT_LE(largest, 1e-6 * strongest) << size;
  }
}

TEST(GridedFeatures, OneCornerPerCell) {
  const cv::Mat image = Texture(640, 480, 1);
  const auto corners = DetectGridedCorners(image, 40, 0.01, 11);
  EXPECT_GT(corners.size(), 150u);
  std::set<std::pair<int, int>> cells;
  for (const auto& corner : corners)
    EXPECT_TRUE(
        cells.insert({static_cast<int>(corner.x) / 40, static_cast<int>(corner.y) / 40}).second);
}

TEST(GridedFeatures, TracksSubpixelShiftsInEveryFrame) {
  const cv::Mat reference = Texture(640, 480, 2);
  std::vector<cv::Mat> frames = {reference};
  std::vector<cv::Point2d> shifts = {{0, 0}};
  for (int i = 1; i < 6; ++i) {
    shifts.emplace_back(0.7 * i, -0.45 * i);
    frames.push_back(Shift(reference, shifts.back().x, shifts.back().y));
  }
  GridedFeatureStats stats;
  const FeatureTracks tracks = TrackGridedFeatures(frames, 0, {}, &stats);
  EXPECT_GT(stats.tracks, 0.9 * stats.corners);
  // Every frame is reached by at least the tracks kept through all of them;
  // the reference by every corner.
  ASSERT_EQ(stats.reached.size(), 6u);
  EXPECT_EQ(stats.reached[0], stats.corners);
  for (int i = 1; i < 6; ++i) {
    EXPECT_GE(stats.reached[i], stats.tracks) << "frame " << i;
    EXPECT_LE(stats.reached[i], stats.corners) << "frame " << i;
  }
  EXPECT_EQ(tracks.num_frames(), 6);
  EXPECT_EQ(tracks.num_tracks(), stats.tracks);
  for (int i = 1; i < 6; ++i) {
    double error = 0.0;
    for (int j = 0; j < tracks.num_tracks(); ++j) {
      const Eigen::Vector2d d = tracks.pixels[i].col(j) - tracks.pixels[0].col(j);
      error += (d - Eigen::Vector2d(shifts[i].x, shifts[i].y)).norm();
    }
    EXPECT_LT(error / tracks.num_tracks(), 0.08) << "frame " << i;
  }
}

// A pure rotation's homography: its Jacobian is the rotation everywhere.
TEST(GridedFeatures, APatchsShapeIsTheFramesMotionsJacobian) {
  const double angle = 2.0 * M_PI / 180.0;
  const cv::Matx33d rotation(std::cos(angle), -std::sin(angle), 30.0, std::sin(angle),
                             std::cos(angle), -12.0, 0.0, 0.0, 1.0);
  const std::array<float, 4> shape = PatchShape(rotation, cv::Point2f(200.0f, 90.0f));
  EXPECT_NEAR(shape[0], std::cos(angle), 1e-6);
  EXPECT_NEAR(shape[1], -std::sin(angle), 1e-6);
  EXPECT_NEAR(shape[2], std::sin(angle), 1e-6);
  EXPECT_NEAR(shape[3], std::cos(angle), 1e-6);
}

// Frames turned about the image centre by up to 3 degrees and moved by up to
// 40 px (a roll under a large tremor): through the shape each frame's motion
// predicts, the tracks land within 0.03 px of the truth on average; as
// translations, twice as far (measured 0.028 against 0.062 px).
TEST(GridedFeatures, PatchesThatTurnKeepTheirTracks) {
  const cv::Mat reference = Texture(640, 480, 4);
  const cv::Point2d centre(320.0, 240.0);
  std::vector<cv::Mat> frames = {reference};
  std::vector<cv::Matx23d> motions = {cv::Matx23d(1, 0, 0, 0, 1, 0)};
  for (int i = 1; i < 5; ++i) {
    const double angle = 0.75 * i * M_PI / 180.0, c = std::cos(angle), s = std::sin(angle);
    const cv::Point2d t(10.0 * i, -4.0 * i);
    motions.emplace_back(c, -s, centre.x + t.x - c * centre.x + s * centre.y, s, c,
                         centre.y + t.y - s * centre.x - c * centre.y);
    cv::Mat frame;
    cv::warpAffine(reference, frame, cv::Mat(motions.back()), reference.size(), cv::INTER_CUBIC,
                   cv::BORDER_REFLECT);
    frames.push_back(frame);
  }
  const auto run = [&](bool predicted_shape, double* mean_error) {
    GridedFeatureOptions options;
    options.predicted_shape = predicted_shape;
    GridedFeatureStats stats;
    const FeatureTracks tracks = TrackGridedFeatures(frames, 0, options, &stats);
    double sum = 0.0;
    int count = 0;
    for (int i = 1; i < 5; ++i)
      for (int j = 0; j < tracks.num_tracks(); ++j) {
        const cv::Vec3d at(tracks.pixels[0](0, j), tracks.pixels[0](1, j), 1.0);
        const cv::Vec2d truth = motions[i] * at;
        sum += std::hypot(tracks.pixels[i](0, j) - truth[0], tracks.pixels[i](1, j) - truth[1]);
        ++count;
      }
    *mean_error = count > 0 ? sum / count : 0.0;
    return std::pair<int, int>(stats.tracks, stats.corners);
  };
  double shaped_error = 0.0, translated_error = 0.0;
  const auto [shaped, corners] = run(true, &shaped_error);
  const int translated = run(false, &translated_error).first;
  std::printf("through the shape %d of %d tracks, %.4f px; as translations %d, %.4f px\n", shaped,
              corners, shaped_error, translated, translated_error);
  EXPECT_GT(shaped, 0.8 * corners);
  EXPECT_LT(shaped_error, 0.05);
  EXPECT_GT(translated_error, 1.5 * shaped_error);
}

TEST(GridedFeatures, ForwardBackwardCheckDropsUntrackablePoints) {
  const cv::Mat reference = Texture(320, 240, 3);
  cv::Mat occluded = Shift(reference, 1.0, 0.0);
  // Replace the right half with unrelated texture: those tracks must go.
  Texture(320, 240, 99).colRange(160, 320).copyTo(occluded.colRange(160, 320));
  const FeatureTracks tracks = TrackGridedFeatures({reference, occluded, occluded}, 0, {});
  int right = 0;
  for (int j = 0; j < tracks.num_tracks(); ++j)
    if (tracks.pixels[0](0, j) > 175) ++right;
  EXPECT_GT(tracks.num_tracks(), 10);
  // KLT can lock onto a chance match in the new texture; nearly all must go.
  EXPECT_LE(right, 4);
}

// A frame that shows something else (a jolt, a smear of blur) loses every
// track: it is left out, and the burst keeps its tracks through the rest.
TEST(GridedFeatures, AFrameThatLosesTheTracksIsLeftOut) {
  const cv::Mat reference = Texture(640, 480, 2);
  std::vector<cv::Mat> frames = {reference};
  for (int i = 1; i < 6; ++i) frames.push_back(Shift(reference, 0.7 * i, -0.45 * i));
  frames[4] = Texture(640, 480, 77);
  GridedFeatureStats stats;
  const FeatureTracks tracks = TrackGridedFeatures(frames, 0, {}, &stats);
  ASSERT_EQ(stats.left_out.size(), 1u);
  EXPECT_EQ(stats.left_out[0].frame, 4);
  EXPECT_LE(stats.left_out[0].tracks_with, 4);
  EXPECT_GT(stats.left_out[0].tracks_without, 0.9 * stats.corners);
  EXPECT_EQ(stats.kept_frames, (std::vector<int>{0, 1, 2, 3, 5}));
  EXPECT_EQ(tracks.num_frames(), 5);
  EXPECT_EQ(tracks.reference, 0);
  EXPECT_EQ(tracks.num_tracks(), stats.tracks);
  EXPECT_EQ(stats.tracks, stats.left_out[0].tracks_without);
  // The last frame kept is the burst's frame 5.
  const Eigen::Vector2d d = tracks.pixels[4].col(0) - tracks.pixels[0].col(0);
  EXPECT_NEAR(d.x(), 3.5, 0.1);
  EXPECT_NEAR(d.y(), -2.25, 0.1);

  GridedFeatureOptions keep_all;
  keep_all.max_frame_track_loss = 1.0;
  GridedFeatureStats all_stats;
  EXPECT_EQ(TrackGridedFeatures(frames, 0, keep_all, &all_stats).num_frames(), 6);
  EXPECT_TRUE(all_stats.left_out.empty());
  EXPECT_LE(all_stats.tracks, 4);
}

// reached[frame][track] for `frames` x `tracks`, every track in every frame
// but where `lost` says.
std::vector<std::vector<uchar>> Reached(int frames, int tracks,
                                        const std::function<bool(int, int)>& lost) {
  std::vector<std::vector<uchar>> reached(frames, std::vector<uchar>(tracks, 1));
  for (int i = 0; i < frames; ++i)
    for (int j = 0; j < tracks; ++j) reached[i][j] = !lost(i, j);
  return reached;
}

TEST(FramesToLeaveOut, BothEndsWhereEachLosesMostTracks) {
  // Frame 0 loses tracks 0-74, frame 9 tracks 25-99: no track reaches all.
  const auto reached =
      Reached(10, 100, [](int i, int j) { return (i == 0 && j < 75) || (i == 9 && j >= 25); });
  const auto left_out = FramesToLeaveOut(reached, 5, {});
  ASSERT_EQ(left_out.size(), 2u);
  EXPECT_EQ(left_out[0].frame, 0);
  EXPECT_EQ(left_out[0].tracks_without, 100);
  EXPECT_EQ(left_out[0].tracks_with, 25);
  EXPECT_EQ(left_out[1].frame, 9);
  EXPECT_EQ(left_out[1].tracks_with, 25);
}

TEST(FramesToLeaveOut, FramesThatLoseTheSameTracksGoTogether) {
  // The last two frames (a smear at the burst's end) lose the same 90 %.
  const auto reached = Reached(10, 100, [](int i, int j) { return i >= 8 && j >= 10; });
  const auto left_out = FramesToLeaveOut(reached, 5, {});
  ASSERT_EQ(left_out.size(), 2u);
  EXPECT_EQ(left_out[0].frame, 8);
  EXPECT_EQ(left_out[1].frame, 9);
  EXPECT_EQ(left_out[1].tracks_without, 100);
  EXPECT_EQ(left_out[1].tracks_with, 10);
}

TEST(FramesToLeaveOut, AFrameThatLosesLessThanTheBoundStays) {
  // Frame 3 keeps 35 of 100 tracks: more than a third.
  const auto reached = Reached(10, 100, [](int i, int j) { return i == 3 && j < 65; });
  EXPECT_TRUE(FramesToLeaveOut(reached, 5, {}).empty());
  GridedFeatureOptions stricter;
  stricter.max_frame_track_loss = 0.5;
  const auto left_out = FramesToLeaveOut(reached, 5, stricter);
  ASSERT_EQ(left_out.size(), 1u);
  EXPECT_EQ(left_out[0].frame, 3);
}

TEST(FramesToLeaveOut, LossesThatCompoundStopAtTheTrackFloor) {
  // Frames 2, 1 and 0 each keep half of what the frames nearer the
  // reference share (a blur that grows toward the burst's start): each within
  // the loss bound, 12 tracks through them all.
  const auto reached =
      Reached(10, 100, [](int i, int j) { return i < 3 && j >= (100 >> (3 - i)); });
  EXPECT_TRUE(FramesToLeaveOut(reached, 5, {}).empty());
  GridedFeatureOptions floor;
  floor.min_shared_tracks = 20;
  const auto left_out = FramesToLeaveOut(reached, 5, floor);
  ASSERT_EQ(left_out.size(), 1u);
  EXPECT_EQ(left_out[0].frame, 0);
  EXPECT_EQ(left_out[0].tracks_without, 25);
  EXPECT_EQ(left_out[0].tracks_with, 12);
  // The floor does not override the frames that must stay: with every frame
  // required, frame 0 joins although the tracks fall below it.
  floor.min_frame_share = 1.0;
  EXPECT_TRUE(FramesToLeaveOut(reached, 5, floor).empty());
}

TEST(FramesToLeaveOut, NeverTheReferenceNorBelowTheFramesKept) {
  // Every frame but the reference (2) loses ten tracks of its own: each
  // keeps at least half of what the frames before it share.
  const auto chain = Reached(6, 60, [](int i, int j) { return i != 2 && j / 10 == i; });
  EXPECT_TRUE(FramesToLeaveOut(chain, 2, {}).empty());
  GridedFeatureOptions options;
  options.max_frame_track_loss = 0.1;
  // Frames 0, 1, 3, 4, 5 lose the same 50 tracks: leaving some out frees
  // nothing while 3 frames must stay, so none is.
  const auto lost_most = Reached(6, 60, [](int i, int j) { return i != 2 && j >= 10; });
  EXPECT_TRUE(FramesToLeaveOut(lost_most, 2, options).empty());
  // 3 frames stay at least: the reference and the two nearest it.
  options.min_frame_share = 0.0;
  const auto left_out = FramesToLeaveOut(chain, 2, options);
  ASSERT_EQ(left_out.size(), 3u);
  EXPECT_EQ(left_out[0].frame, 0);
  EXPECT_EQ(left_out[1].frame, 4);
  EXPECT_EQ(left_out[2].frame, 5);
  options.max_frame_track_loss = 1.0;
  EXPECT_TRUE(FramesToLeaveOut(chain, 2, options).empty());
}

}  // namespace
}  // namespace dfsm
