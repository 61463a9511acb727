// Memory amplification against the real dfsmd at its default configuration
// (label daemon; the hardening issue's item 5 and the per-connection bound of
// item 2). Each reproduction used to take the daemon beyond the unit's
// MemoryMax=2G; each is now bounded by a limit of the configuration, and the
// test asserts that bound on the kernel's peak resident set (VmHWM, reset
// through /proc/PID/clear_refs before each attack), not a guess at the code:
//  - frames over limits.max_frame_pixels are refused from their headers: the
//    issue's four black 8192x8192 PNGs (266 KB on the wire; one such job
//    alone peaked at 1.9 GB);
//  - queued uploads hold their frames on disk: eight queued bursts at the
//    default limits cost what one job costs, never eight (one worker);
//  - uploads stream to a staging file: four concurrent uploads grow the
//    daemon by a fraction of one of them;
//  - burst.tar streams: four concurrent downloads of a large kept burst
//    likewise;
//  - a request head without an end costs at most server.max_head_bytes;
//  - JPEGs with thousands of scans (CPU, item 6) are refused by the job
//    before decoding, and eight such uploads at once leave /healthz
//    answering;
//  - grid=1 is held to the feature grid's bound (8192 cells);
//  - a Range of 2700 ranges gets a job file or a page file once, streamed
//    (httplib built a multipart body of every range: 3.3 GB, bad_alloc).
// Every number is printed, so the table in docs/daemon.md is this test's
// output. Under a sanitizer the suite skips: the peaks would be its shadow
// memory, not dfsmd's (TSan: grid=1 peaked at +1.6 GiB and took 231 s), and
// the refusals it exercises run under ASan in the hostile and fuzz suites.
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <thread>

#include "core/io/file_util.h"
#include "core/synth/burst_synthesizer.h"
#include "daemon/service/config.h"
#include "tests/daemon/fault_helpers.h"

namespace dfsm::test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr int64_t kMiB = 1 << 20;
// systemd/dfsmd.service's MemoryMax.
constexpr int64_t kMemoryMax = 2048 * kMiB;

int64_t StatusBytes(pid_t pid, const std::string& field) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(status, line);)
    if (line.rfind(field + ":", 0) == 0) return std::stoll(line.substr(field.size() + 1)) * 1024;
  return -1;
}

// The peak resident set of `pid` while `attack` runs, over the resident set
// before it. Writing 5 to clear_refs resets VmHWM to the current RSS.
struct Growth {
  int64_t before = 0, peak = 0;
  int64_t grown() const { return peak - before; }
};
template <typename Attack>
Growth PeakGrowth(pid_t pid, Attack attack) {
  std::ofstream("/proc/" + std::to_string(pid) + "/clear_refs") << "5";
  Growth growth;
  growth.before = StatusBytes(pid, "VmRSS");
  attack();
  growth.peak = StatusBytes(pid, "VmHWM");
  return growth;
}

void Report(const std::string& attack, const Growth& growth, int64_t bound) {
  std::cout << attack << ": RSS " << growth.before / kMiB << " MiB before, peak "
            << growth.peak / kMiB << " MiB, +" << growth.grown() / kMiB << " MiB (bound "
            << bound / kMiB << " MiB)\n";
  EXPECT_LE(growth.grown(), bound) << attack;
  EXPECT_LT(growth.peak, kMemoryMax) << attack;
}

// A burst directory as an uncompressed tar, written by the system's tar
// (the form a user uploads); returns its bytes.
std::string TarOf(const fs::path& burst) {
  const fs::path tar = burst.string() + ".tar";
  const std::string command =
      "tar -C '" + burst.string() + "' -cf '" + tar.string() + "' manifest.json frames";
  EXPECT_EQ(std::system(command.c_str()), 0) << command;
  return ReadFileToString(tar);
}

void WriteManifest(const fs::path& burst, int width, int height, int frames,
                   const std::string& pixel_format) {
  json list = json::array();
  for (int i = 0; i < frames; ++i) {
    char name[32];
    std::snprintf(name, sizeof(name), "frames/%06d.png", i);
    list.push_back({{"file", name}, {"timestamp_ns", i * 33'333'333LL}, {"sequence", i}});
  }
  const json manifest = {{"format", "dfsm-burst/1"}, {"width", width},
                         {"height", height},         {"pixel_format", pixel_format},
                         {"reference", frames / 2},  {"frames", list}};
  WriteFileAtomically(burst / "manifest.json", manifest.dump(2));
}

// `frames` frames of independent uniform noise: incompressible PNGs (about
// 230 KB each at 320x240), and a job that fails quickly for want of tracks.
fs::path WriteNoiseBurst(const fs::path& burst, int width, int height, int frames) {
  fs::create_directories(burst / "frames");
  cv::RNG rng(7);
  for (int i = 0; i < frames; ++i) {
    cv::Mat image(height, width, CV_8UC3);
    rng.fill(image, cv::RNG::UNIFORM, 0, 256);
    char name[32];
    std::snprintf(name, sizeof(name), "frames/%06d.png", i);
    EXPECT_TRUE(cv::imwrite((burst / name).string(), image, {cv::IMWRITE_PNG_COMPRESSION, 1}));
  }
  WriteManifest(burst, width, height, frames, "bgr8");
  return burst;
}

httplib::Result Upload(httplib::Client& client, const std::string& tar,
                       const std::string& query = "") {
  return client.Post(("/api/v1/jobs" + query).c_str(), tar, "application/x-tar");
}

class DfsmdAmplificationTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = fs::temp_directory_path() / ("dfsmd-amplification-test-" + std::to_string(::getpid()));
    fs::remove_all(root_);
    WriteTestBurst(root_ / "replay");
  }
  static void TearDownTestSuite() { fs::remove_all(root_); }

  // dfsmd at its defaults: only the port, the state directory and the replay
  // source are set.
  void SetUp() override {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
    GTEST_SKIP() << "under a sanitizer the peak is its shadow memory, not dfsmd's";
#endif
    dir_ = root_ / ::testing::UnitTest::GetInstance()->current_test_info()->name();
    fs::create_directories(dir_ / "state");
    daemon_ = std::make_unique<DfsmdProcess>(
        DFSMD_BINARY,
        std::vector<std::string>{"--capture.source", "replay:" + (root_ / "replay").string(),
                                 "--jobs.state_dir", (dir_ / "state").string()},
        dir_ / "dfsmd.log");
    ASSERT_TRUE(daemon_->ok()) << daemon_->Log();
  }

  httplib::Client Client() const {
    httplib::Client client = daemon_->Client();
    client.set_read_timeout(std::chrono::seconds(300));
    client.set_write_timeout(std::chrono::seconds(300));
    return client;
  }

  static fs::path root_;
  fs::path dir_;
  std::unique_ptr<DfsmdProcess> daemon_;
};

fs::path DfsmdAmplificationTest::root_;

// `frames` black frames of width x height as a gray8 burst tar (a PNG of
// zeros compresses about 1000:1, so the upload is small and the decoded
// burst large).
std::string BlackBurstTar(const fs::path& burst, int width, int height, int frames) {
  fs::create_directories(burst / "frames");
  const cv::Mat black = cv::Mat::zeros(height, width, CV_8UC1);
  EXPECT_TRUE(cv::imwrite((burst / "frames/000000.png").string(), black));
  for (int i = 1; i < frames; ++i) {
    char name[32];
    std::snprintf(name, sizeof(name), "frames/%06d.png", i);
    fs::copy_file(burst / "frames/000000.png", burst / name);
  }
  WriteManifest(burst, width, height, frames, "gray8");
  return TarOf(burst);
}

TEST_F(DfsmdAmplificationTest, FramesOverTheFrameLimitAreRefusedBeforeDecoding) {
  // The issue's reproduction: four black 8192x8192 PNGs, 266 KB on the wire,
  // eight times. Queued and decoded they took +2.0 GB; one such job alone
  // peaks at 1.9 GB in its feature stage, so limits.max_frame_pixels (4K
  // UHD by default) refuses them from their PNG headers.
  const std::string tar = BlackBurstTar(dir_ / "black", 8192, 8192, 4);
  httplib::Client client = Client();
  const Growth growth = PeakGrowth(daemon_->pid(), [&] {
    for (int i = 0; i < 8; ++i) {
      const auto result = Upload(client, tar);
      ASSERT_TRUE(result);
      EXPECT_TRUE(result->status == 413 || result->status == 422) << result->status;
      EXPECT_NE(result->body.find("limits.max_frame_pixels"), std::string::npos) << result->body;
    }
  });
  Report("8 uploads of 4 x 8192^2 PNGs", growth, 16 * kMiB);
}

TEST_F(DfsmdAmplificationTest, QueuedUploadsHoldTheirFramesOnDisk) {
  // A burst at both default limits: frames of limits.max_frame_pixels, as
  // many as limits.max_burst_pixels admits.
  const service::LimitsSection limits;
  const int width = 4096, height = static_cast<int>(limits.max_frame_pixels / width);
  const int frames = static_cast<int>(limits.max_burst_pixels / limits.max_frame_pixels);
  const std::string tar = BlackBurstTar(dir_ / "black", width, height, frames);
  std::cout << "upload: " << tar.size() / 1024 << " KiB, " << frames << " x " << width << " x "
            << height << "\n";

  httplib::Client client = Client();
  // One job alone: what a worker needs for the largest admitted burst.
  const Growth alone = PeakGrowth(daemon_->pid(), [&] {
    const std::string location = AcceptedLocation(Upload(client, tar));
    ASSERT_FALSE(location.empty());
    AwaitFinished(client, location);
  });
  Report("1 upload at the limits", alone, kMemoryMax);

  // Eight queued (jobs.queue) with one worker: they wait as files, so the
  // peak is still one job's (eight decoded would be 8 x 64 Mi gray pixels).
  std::vector<std::string> jobs;
  const Growth queued = PeakGrowth(daemon_->pid(), [&] {
    for (int i = 0; i < 8; ++i) {
      const std::string location = AcceptedLocation(Upload(client, tar));
      if (!location.empty()) jobs.push_back(location);
    }
    for (const std::string& location : jobs) AwaitFinished(client, location);
  });
  ASSERT_EQ(jobs.size(), 8u);
  Report("8 queued uploads at the limits", queued, alone.grown() + 64 * kMiB);
  // Beside the default ring at 1080p ((ring_frames + 1) x 1920 x 1080 x 4
  // bytes: gray and BGR) the worst admitted job still fits MemoryMax.
  const int64_t ring_1080p = int64_t{service::CaptureSection{}.ring_frames + 1} * 1920 * 1080 * 4;
  EXPECT_LT(ring_1080p + queued.peak, kMemoryMax);
  for (const std::string& location : jobs) {
    const json job = json::parse(client.Get(location.c_str())->body);
    EXPECT_EQ(job["status"], "failed") << job.dump();  // black frames: no texture to track
    EXPECT_NE(job.value("error", "").find("no texture"), std::string::npos) << job.dump();
  }
}

TEST_F(DfsmdAmplificationTest, ConcurrentUploadsAndBurstDownloadsStream) {
  // 250 frames of 320x240 noise: a tar of about 55 MiB (server.max_body_bytes
  // is 256 MiB). The jobs keep 3 frames (?frames=3), so what the peak
  // measures is the upload, not the pipeline.
  const std::string tar = TarOf(WriteNoiseBurst(dir_ / "noise", 320, 240, 250));
  std::cout << "upload: " << tar.size() / kMiB << " MiB, 250 x 320 x 240 noise\n";
  ASSERT_GT(static_cast<int64_t>(tar.size()), 40 * kMiB);

  std::vector<std::string> jobs(4);
  const Growth uploads = PeakGrowth(daemon_->pid(), [&] {
    std::vector<std::thread> clients;
    for (int i = 0; i < 4; ++i)
      clients.emplace_back([&, i] {
        httplib::Client client = Client();
        jobs[i] = AcceptedLocation(Upload(client, tar, "?frames=3"));
      });
    for (std::thread& thread : clients) thread.join();
  });
  // The bodies stream to staging files; read whole, four of them were
  // +1.1 GB at 255 MiB. What remains is httplib's and the gate's buffers.
  Report("4 concurrent uploads of " + std::to_string(tar.size() / kMiB) + " MiB", uploads,
         64 * kMiB);

  httplib::Client client = Client();
  for (const std::string& location : jobs) {
    ASSERT_FALSE(location.empty());
    const json job = AwaitFinished(client, location);
    ASSERT_TRUE(job["links"].contains("burst")) << job.dump();
  }
  const std::string burst_link =
      json::parse(client.Get(jobs[0].c_str())->body)["links"]["burst"].get<std::string>();

  std::atomic<int64_t> downloaded{0};
  const Growth downloads = PeakGrowth(daemon_->pid(), [&] {
    std::vector<std::thread> clients;
    for (int i = 0; i < 4; ++i)
      clients.emplace_back([&] {
        httplib::Client client = Client();
        const auto result = client.Get(burst_link.c_str());
        ASSERT_TRUE(result);
        ASSERT_EQ(result->status, 200);
        downloaded += static_cast<int64_t>(result->body.size());
      });
    for (std::thread& thread : clients) thread.join();
  });
  // Each download reads the burst's files a piece at a time; four whole
  // 245 MiB bursts in memory were +2.9 GB.
  EXPECT_GE(downloaded.load(), 4 * static_cast<int64_t>(tar.size()) * 9 / 10);
  Report("4 concurrent downloads of burst.tar (" + std::to_string(downloaded / 4 / kMiB) + " MiB)",
         downloads, 64 * kMiB);
}

TEST_F(DfsmdAmplificationTest, ManyRangesCostOneStreamedCopy) {
  httplib::Client client = Client();
  const std::string job = AcceptedLocation(
      client.Post("/api/v1/captures", R"({"frames":10,"when":"next"})", "application/json"));
  ASSERT_EQ(AwaitFinished(client, job)["status"], "succeeded");
  const std::string file = job + "/depth_filled.tiff";
  const size_t size = client.Get(file.c_str())->body.size();
  std::string ranges = "bytes=0-";
  for (int i = 1; i < 2700; ++i) ranges += ",0-";
  const httplib::Headers headers = {{"Range", ranges}};
  std::atomic<int> whole{0};
  const Growth growth = PeakGrowth(daemon_->pid(), [&] {
    std::vector<std::thread> clients;
    for (int i = 0; i < 4; ++i)
      clients.emplace_back([&, i] {
        httplib::Client attacker = Client();
        const auto result = i % 2 ? attacker.Head("/ui/vendor/three.core.min.js", headers)
                                  : attacker.Get(file.c_str(), headers);
        if (result && result->status == 200 && !result->has_header("Content-Range")) ++whole;
      });
    for (std::thread& thread : clients) thread.join();
  });
  EXPECT_EQ(whole.load(), 4);
  Report("4 requests of 2700 ranges (" + std::to_string(size / 1024) + " KiB job file, page file)",
         growth, 64 * kMiB);
  const auto health = client.Get("/healthz");
  ASSERT_TRUE(health);
  EXPECT_EQ(health->status, 200);
}

TEST_F(DfsmdAmplificationTest, AHeadWithoutAnEndCostsAtMostTheHeadLimit) {
  // 64 MiB of request line with no newline (the issue's 1 GiB took RSS from
  // 688 MB to 2.5 GB): the gate closes the connection at server.max_head_bytes.
  int64_t sent = 0;
  const Growth growth = PeakGrowth(daemon_->pid(), [&] {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(static_cast<uint16_t>(daemon_->port()));
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)), 0);
    const std::string piece = "GET /" + std::string(kMiB, 'a');
    for (int i = 0; i < 64; ++i) {
      const ssize_t n = ::send(fd, piece.data(), piece.size(), MSG_NOSIGNAL);
      if (n <= 0) break;  // refused: the connection is closed
      sent += n;
    }
    ::close(fd);
  });
  std::cout << "sent " << sent / 1024 << " KiB of request line before the connection closed\n";
  EXPECT_LT(sent, 64 * kMiB);
  Report("an endless request line", growth, 16 * kMiB);
  httplib::Client client = Client();
  const auto health = client.Get("/healthz");
  ASSERT_TRUE(health);
  EXPECT_EQ(health->status, 200);
}

// A progressive JPEG of `frame` with `extra` copies of its last scan before
// the end-of-image marker: libjpeg decodes every scan, each a pass over the
// whole frame (the hardening issue's 87 000 scans took 17.7 s a frame).
std::string ManyScanJpeg(const cv::Mat& frame, int extra) {
  std::vector<uchar> bytes;
  EXPECT_TRUE(cv::imencode(".jpg", frame, bytes, {cv::IMWRITE_JPEG_PROGRESSIVE, 1}));
  const std::string jpeg(bytes.begin(), bytes.end());
  const size_t last_scan = jpeg.rfind("\xFF\xDA");
  const size_t end = jpeg.size() - 2;  // FF D9
  std::string crafted = jpeg.substr(0, end);
  for (int i = 0; i < extra; ++i) crafted.append(jpeg, last_scan, end - last_scan);
  return crafted + "\xFF\xD9";
}

TEST_F(DfsmdAmplificationTest, JpegsWithThousandsOfScansNeitherStarveHealthzNorRun) {
  // Eight uploads at once of three such frames each. Decoded on the HTTP
  // threads they kept /healthz from answering for about 75 s; now the upload
  // reads only each header, and the job refuses the scans before decoding.
  const fs::path burst = dir_ / "scans";
  fs::create_directories(burst / "frames");
  // A flat frame: its last scan is a few bytes, so 20 000 of them are small.
  const std::string jpeg = ManyScanJpeg(cv::Mat(480, 640, CV_8UC1, cv::Scalar(128)), 20000);
  std::cout << "frame: " << jpeg.size() / 1024 << " KiB\n";
  json list = json::array();
  for (int i = 0; i < 3; ++i) {
    const std::string name = "frames/00000" + std::to_string(i) + ".jpg";
    WriteFileAtomically(burst / name, jpeg);
    list.push_back({{"file", name}});
  }
  WriteFileAtomically(
      burst / "manifest.json",
      json({{"format", "dfsm-burst/1"}, {"width", 640}, {"height", 480}, {"frames", list}}).dump());
  const std::string tar = TarOf(burst);

  std::atomic<bool> done{false};
  struct Answer {
    int status = 0;  // 0: no answer
    std::string body, location;
  };
  std::vector<Answer> answers(8);
  std::vector<std::thread> clients;
  for (int i = 0; i < 8; ++i)
    clients.emplace_back([&, i] {
      httplib::Client client = Client();
      const auto result = Upload(client, tar);
      if (result) answers[i] = {result->status, result->body, result->get_header_value("Location")};
    });
  std::thread joiner([&] {
    for (std::thread& thread : clients) thread.join();
    done = true;
  });
  httplib::Client probe = daemon_->Client();
  probe.set_read_timeout(std::chrono::seconds(5));
  std::vector<int64_t> times;
  while (!done || times.empty()) {
    const auto start = std::chrono::steady_clock::now();
    const auto result = probe.Get("/healthz");
    const auto took = std::chrono::duration_cast<std::chrono::milliseconds>(
                          std::chrono::steady_clock::now() - start)
                          .count();
    times.push_back(result && result->status == 200 ? took : 10000);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  joiner.join();
  std::sort(times.begin(), times.end());
  std::cout << "8 uploads of 3 JPEGs with 20 000 scans: /healthz median " << times[times.size() / 2]
            << " ms, worst " << times.back() << " ms over " << times.size() << " probes\n";
  // As the hostile tests: the median within 1 s, one scheduling hiccup of a
  // loaded machine allowed up to 3 s.
  EXPECT_LT(times[times.size() / 2], 1000);
  EXPECT_LT(times.back(), 3000);

  httplib::Client client = Client();
  for (const Answer& answer : answers) {
    std::string reason = answer.body;
    if (answer.status == 202) {
      const json job = AwaitFinished(client, answer.location);
      EXPECT_EQ(job["status"], "failed") << job.dump();
      reason = job.value("error", "");
    } else {
      EXPECT_TRUE(answer.status == 413 || answer.status == 422) << answer.status;
    }
    EXPECT_NE(reason.find("scans"), std::string::npos) << reason;
  }
}

TEST_F(DfsmdAmplificationTest, GridOneIsHeldToTheFeatureGridBound) {
  // A textured 1280x960 burst with grid=1: 1.2 M cells asked for took 86 s
  // and +1.5 GB; the grid is widened to at most 8192 cells.
  SynthOptions options;
  options.width = 1280;
  options.height = 960;
  options.frames = 10;
  options.seed = 5;
  const fs::path burst = dir_ / "textured";
  WriteSynthBurst(burst, SynthesizeBurst(options));
  const std::string tar = TarOf(burst);

  httplib::Client client = Client();
  json job;
  const Growth growth = PeakGrowth(daemon_->pid(), [&] {
    const std::string location = AcceptedLocation(Upload(client, tar, "?grid=1"));
    ASSERT_FALSE(location.empty());
    job = AwaitFinished(client, location, std::chrono::seconds(300));
  });
  ASSERT_EQ(job["status"], "succeeded") << job.dump();
  const json result = json::parse(client.Get((job["links"]["files"][0].get<std::string>()).c_str())
                                      ->body);  // result.json comes first
  ASSERT_TRUE(result.contains("sparse")) << result.dump();
  EXPECT_LE(result["sparse"]["features"].get<int>(), 8192);
  std::cout << "grid=1 at 1280x960: " << result["sparse"]["features"] << " features, "
            << result["timings_ms"].dump() << "\n";
  Report("grid=1 at 1280x960", growth, 768 * kMiB);
}

}  // namespace
}  // namespace dfsm::test
