// CPU per frame of the capture path: luma extraction and colour conversion of
// the V4L2 formats at 1080p, MJPEG decoding, and publishing into the ring.
//
//   build/bench/capture_bench --benchmark_format=json
#include <benchmark/benchmark.h>
#include <linux/videodev2.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "daemon/capture/frame_ring.h"
#include "daemon/capture/mjpeg_decoder.h"
#include "daemon/capture/pixel_convert.h"

namespace {

using dfsm::capture::FrameLayout;

constexpr int kWidth = 1920, kHeight = 1080;

// A frame with structure (so JPEG sizes are realistic), as packed YUYV.
cv::Mat TestBgr() {
  cv::Mat bgr(kHeight, kWidth, CV_8UC3);
  cv::randu(bgr, 0, 255);
  cv::GaussianBlur(bgr, bgr, cv::Size(0, 0), 3.0);
  return bgr;
}

std::vector<uint8_t> Yuyv(const cv::Mat& bgr) {
  cv::Mat yuv;
  cv::cvtColor(bgr, yuv, cv::COLOR_BGR2YUV);
  std::vector<uint8_t> out(static_cast<size_t>(kWidth) * kHeight * 2);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      const cv::Vec3b p = yuv.at<cv::Vec3b>(y, x);
      out[(static_cast<size_t>(y) * kWidth + x) * 2] = p[0];
      out[(static_cast<size_t>(y) * kWidth + x) * 2 + 1] = (x % 2 == 0) ? p[1] : p[2];
    }
  return out;
}

void Convert(benchmark::State& state, uint32_t fourcc, bool color) {
  const cv::Mat bgr = TestBgr();
  std::vector<uint8_t> data;
  FrameLayout layout{fourcc, kWidth, kHeight, kWidth, 0};
  dfsm::capture::MjpegDecoder decoder;
  if (fourcc == V4L2_PIX_FMT_YUYV) {
    data = Yuyv(bgr);
    layout.bytesperline = 2 * kWidth;
  } else if (fourcc == V4L2_PIX_FMT_NV12) {
    data.assign(static_cast<size_t>(kWidth) * kHeight * 3 / 2, 128);
    cv::Mat gray;
    cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
    std::copy(gray.datastart, gray.dataend, data.begin());
  } else {
    cv::imencode(".jpg", bgr, data, {cv::IMWRITE_JPEG_QUALITY, 85});
  }
  layout.sizeimage = data.size();
  cv::Mat gray, bgr_out;
  for (auto _ : state) {
    dfsm::capture::ConvertFrame(data.data(), data.size(), layout, gray, color ? &bgr_out : nullptr,
                                &decoder);
    benchmark::DoNotOptimize(gray.data);
  }
  state.counters["fps"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

void BM_YuyvToGray1080p(benchmark::State& s) { Convert(s, V4L2_PIX_FMT_YUYV, false); }
void BM_YuyvToGrayAndBgr1080p(benchmark::State& s) { Convert(s, V4L2_PIX_FMT_YUYV, true); }
void BM_Nv12ToGray1080p(benchmark::State& s) { Convert(s, V4L2_PIX_FMT_NV12, false); }
void BM_Nv12ToGrayAndBgr1080p(benchmark::State& s) { Convert(s, V4L2_PIX_FMT_NV12, true); }
void BM_MjpegToGray1080p(benchmark::State& s) { Convert(s, V4L2_PIX_FMT_MJPEG, false); }
void BM_MjpegToGrayAndBgr1080p(benchmark::State& s) { Convert(s, V4L2_PIX_FMT_MJPEG, true); }

// The scalar alternative ExtractPackedLuma replaced, for comparison.
void BM_YuyvToGray1080pExtractChannel(benchmark::State& state) {
  const std::vector<uint8_t> data = Yuyv(TestBgr());
  const cv::Mat packed(kHeight, kWidth, CV_8UC2, const_cast<uint8_t*>(data.data()));
  cv::Mat gray;
  for (auto _ : state) {
    cv::extractChannel(packed, gray, 0);
    benchmark::DoNotOptimize(gray.data);
  }
}

// Publishing a frame (the capture thread's share of the ring), with and
// without writing a 1080p gray frame into the staging buffer.
void BM_RingPublish(benchmark::State& state) {
  const bool copy = state.range(0) != 0;
  dfsm::capture::FrameRing ring(64);
  ring.Preallocate(kWidth, kHeight, false);
  const cv::Mat frame(kHeight, kWidth, CV_8UC1, cv::Scalar(7));
  int64_t sequence = 0;
  for (auto _ : state) {
    dfsm::capture::FrameSlot* slot = ring.Staging();
    if (copy) frame.copyTo(slot->gray);
    ring.Publish(sequence++);
  }
}

BENCHMARK(BM_YuyvToGray1080p)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_YuyvToGray1080pExtractChannel)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_YuyvToGrayAndBgr1080p)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Nv12ToGray1080p)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Nv12ToGrayAndBgr1080p)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_MjpegToGray1080p)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_MjpegToGrayAndBgr1080p)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RingPublish)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
