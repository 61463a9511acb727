// End-to-end tests of the real dfsmd binary on a loopback port, capturing from
// the replay source of a generated burst with ground truth (label "daemon").
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>

#include <algorithm>
#include <iostream>
#include <opencv2/imgcodecs.hpp>

#include "core/io/burst.h"
#include "core/io/ground_truth.h"
#include "core/pipeline/evaluation.h"
#include "core/synth/burst_synthesizer.h"
#include "daemon/service/tar_extract.h"
#include "dfsmd/dfsmd_process.h"
#include "tests/daemon/fault_helpers.h"
#include "tests/support/tar_files.h"

namespace dfsm::test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// How long a job of these small bursts may take before the test fails.
constexpr std::chrono::seconds kJobTimeout(60);

class DfsmdTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = fs::temp_directory_path() / ("dfsmd-test-" + std::to_string(::getpid()));
    fs::remove_all(root_);
    SynthOptions options;
    options.width = 320;
    options.height = 240;
    options.frames = 10;
    options.seed = 3;
    WriteSynthBurst(root_ / "burst", SynthesizeBurst(options));
  }
  static void TearDownTestSuite() { fs::remove_all(root_); }

  void SetUp() override {
    dir_ = root_ / ::testing::UnitTest::GetInstance()->current_test_info()->name();
    fs::create_directories(dir_);
  }

  std::vector<std::string> Args(const std::vector<std::string>& extra = {}) const {
    std::vector<std::string> args = {"--capture.source",  "replay:" + (root_ / "burst").string(),
                                     "--jobs.state_dir",  (dir_ / "state").string(),
                                     "--pipeline.planes", "64"};
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  }

  std::unique_ptr<DfsmdProcess> Start(const std::vector<std::string>& extra = {}) {
    auto daemon = std::make_unique<DfsmdProcess>(DFSMD_BINARY, Args(extra), dir_ / "dfsmd.log");
    EXPECT_TRUE(daemon->ok()) << daemon->Log();
    return daemon;
  }

  static std::string Accepted(const httplib::Result& result) {
    EXPECT_TRUE(result);
    if (!result) return "";
    EXPECT_EQ(result->status, 202) << result->body;
    const json body = json::parse(result->body);
    EXPECT_EQ(body["status"], "queued");
    EXPECT_EQ(result->get_header_value("Location"), "/api/v1/jobs/" + body.value("id", ""));
    return result->get_header_value("Location");
  }

  // Triggers a capture and waits until a worker has taken it; its Location.
  static std::string CaptureTakenByAWorker(httplib::Client& client) {
    const std::string location = Accepted(
        client.Post("/api/v1/captures", R"({"frames":10,"when":"next"})", "application/json"));
    while (json::parse(client.Get(location.c_str())->body)["status"] == "queued") {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return location;
  }

  // `signal` while a job runs: dfsmd finishes and records the job, leaves no
  // staging behind and exits 0.
  void ExpectStopFinishesTheRunningJob(int signal, const std::string& name) {
    auto daemon = Start();
    httplib::Client client = daemon->Client();
    const std::string location = CaptureTakenByAWorker(client);
    EXPECT_EQ(daemon->Stop(signal), 0) << daemon->Log();
    const std::string id = location.substr(location.rfind('/') + 1);
    const json record = json::parse(ReadFileToString(dir_ / "state" / "jobs" / id / "job.json"));
    EXPECT_EQ(record["status"], "succeeded");
    EXPECT_NE(daemon->Log().find(name + ", shutting down"), std::string::npos);
    EXPECT_TRUE(fs::is_empty(dir_ / "state" / "tmp"));
  }

  static void ExpectProblem(const httplib::Result& result, int status) {
    ASSERT_TRUE(result);
    EXPECT_EQ(result->status, status) << result->body;
    EXPECT_EQ(result->get_header_value("Content-Type"), "application/problem+json");
    EXPECT_FALSE(json::parse(result->body).value("detail", "").empty());
  }

  // The depth of a finished job against the burst's ground truth.
  static DepthEvaluation ScoreDepth(httplib::Client& client, const std::string& location) {
    auto tiff = client.Get((location + "/depth.tiff").c_str());
    EXPECT_EQ(tiff->status, 200);
    EXPECT_EQ(tiff->get_header_value("Content-Type"), "image/tiff");
    const cv::Mat depth = cv::imdecode(std::vector<uchar>(tiff->body.begin(), tiff->body.end()),
                                       cv::IMREAD_UNCHANGED);
    EXPECT_EQ(depth.type(), CV_32FC1);
    EXPECT_EQ(depth.size(), cv::Size(320, 240));
    const GroundTruth truth = ReadGroundTruth(root_ / "burst");
    const Burst burst = ReadBurst(root_ / "burst");
    const DepthEvaluation score = EvaluateDepth(depth, truth.depth, TexturedMask(burst.gray[0]));
    std::cout << "depth against ground truth: " << json(ToJson(score)).dump() << "\n";
    return score;
  }

  static fs::path root_;
  fs::path dir_;
};

fs::path DfsmdTest::root_;

TEST_F(DfsmdTest, CaptureThenFetchEveryOutput) {
  auto daemon = Start();
  httplib::Client client = daemon->Client();
  // "next" + the replayed burst's length: exactly one pass, frame 0 first, so
  // the reference view is the one the ground truth describes.
  const std::string location = Accepted(
      client.Post("/api/v1/captures", R"({"frames":10,"when":"next"})", "application/json"));
  const json job = AwaitFinished(client, location, kJobTimeout);
  ASSERT_EQ(job["status"], "succeeded") << job.dump(2);
  EXPECT_EQ(job["origin"], "capture");
  EXPECT_EQ(job["input"]["frames"], 10);
  EXPECT_GT(job["timings_ms"]["total"].get<double>(), 0.0);

  const std::map<std::string, std::string> types = {
      {"result.json", "application/json"},
      {"depth.tiff", "image/tiff"},
      {"depth.png", "image/png"},
      {"preview.png", "image/png"},
      {"confidence.png", "image/png"},
      {"points.ply", "application/octet-stream"},
      {"sparse_points.ply", "application/octet-stream"},
      {"calibration.json", "application/json"},
      {"calibration.yaml", "application/yaml"},
      {"burst.tar", "application/x-tar"}};
  for (const auto& [file, type] : types) {
    auto result = client.Get((location + "/" + file).c_str());
    ASSERT_TRUE(result) << file;
    EXPECT_EQ(result->status, 200) << file;
    EXPECT_EQ(result->get_header_value("Content-Type"), type) << file;
    const std::string& body = result->body;
    if (type == "image/png") {
      EXPECT_FALSE(
          cv::imdecode(std::vector<uchar>(body.begin(), body.end()), cv::IMREAD_UNCHANGED).empty())
          << file;
    } else if (type == "application/octet-stream") {
      EXPECT_EQ(body.rfind("ply\nformat binary_little_endian", 0), 0u) << file;
    } else if (file == "calibration.yaml") {
      EXPECT_EQ(body.rfind("%YAML", 0), 0u);
    } else if (file == "burst.tar") {
      // Sent chunked: libarchive writes it as it goes, its size unknown ahead.
      EXPECT_EQ(result->get_header_value("Transfer-Encoding"), "chunked");
      fs::create_directories(dir_ / "downloaded");
      service::ExtractTar(body, dir_ / "downloaded", {});
      EXPECT_EQ(service::CollectFiles(dir_ / "downloaded").size(), 11u);  // manifest + 10 frames
      EXPECT_EQ(json::parse(ReadFileToString(dir_ / "downloaded" /
                                             "manifest.json"))["source"]["source_sequence_first"],
                0);
    }
  }
  const json result = json::parse(client.Get((location + "/result.json").c_str())->body);
  EXPECT_EQ(result["status"], "ok");
  EXPECT_EQ(result["format"], "dfsm-result/1");
  const DepthEvaluation score = ScoreDepth(client, location);
  EXPECT_LT(score.abs_rel, 0.10) << json(ToJson(score)).dump();
  EXPECT_GT(score.coverage, 0.5) << json(ToJson(score)).dump();

  const json calibration = json::parse(client.Get("/api/v1/calibration")->body);
  EXPECT_EQ("/api/v1/jobs/" + calibration["job"].get<std::string>(), location);
  EXPECT_GT(calibration["calibration"]["fx"].get<double>(), 0.0);
  const json camera = json::parse(client.Get("/api/v1/camera")->body);
  EXPECT_EQ(camera["driver"], "replay");
  EXPECT_GT(camera["frames_captured"].get<int>(), 10);
  auto snapshot = client.Get("/api/v1/snapshot.jpg");
  EXPECT_EQ(snapshot->get_header_value("Content-Type"), "image/jpeg");
  EXPECT_EQ(cv::imdecode(std::vector<uchar>(snapshot->body.begin(), snapshot->body.end()),
                         cv::IMREAD_UNCHANGED)
                .size(),
            cv::Size(320, 240));
  // A live view asks for the width it shows; the aspect is kept.
  snapshot = client.Get("/api/v1/snapshot.jpg?width=160");
  EXPECT_EQ(cv::imdecode(std::vector<uchar>(snapshot->body.begin(), snapshot->body.end()),
                         cv::IMREAD_UNCHANGED)
                .size(),
            cv::Size(160, 120));
  EXPECT_EQ(client.Get("/api/v1/snapshot.jpg?width=4000")->status, 200);
  snapshot = client.Get("/api/v1/snapshot.jpg?width=8");
  EXPECT_EQ(snapshot->status, 400);
  EXPECT_NE(snapshot->body.find("'width' must be in [16, 8192], got 8"), std::string::npos);
  const std::string metrics = client.Get("/metrics")->body;
  EXPECT_NE(metrics.find("dfsmd_jobs_total{outcome=\"succeeded\"} 1"), std::string::npos);
  EXPECT_NE(metrics.find("dfsmd_stage_duration_seconds_count{stage=\"dense\"} 1"),
            std::string::npos);
  EXPECT_EQ(client.Get("/readyz")->status, 200);

  // The downloaded burst.tar uploads again as the same burst, to the same result.
  const std::string burst_tar = client.Get((location + "/burst.tar").c_str())->body;
  // A Range is answered with all of it (its size is not known ahead), and
  // curl -O saves what the client read.
  const auto ranged = client.Get((location + "/burst.tar").c_str(), {{"Range", "bytes=0-9"}});
  EXPECT_EQ(ranged->status, 200);
  EXPECT_EQ(ranged->body, burst_tar);
  if (std::system("command -v curl >/dev/null 2>&1") == 0) {
    const std::string url =
        "http://127.0.0.1:" + std::to_string(daemon->port()) + location + "/burst.tar";
    ASSERT_EQ(std::system(("cd " + dir_.string() + " && curl -sfO " + url).c_str()), 0);
    EXPECT_EQ(ReadFileToString(dir_ / "burst.tar"), burst_tar);
  }
  const std::string again =
      Accepted(client.Post("/api/v1/jobs?frames=10", burst_tar, "application/x-tar"));
  const json redone = AwaitFinished(client, again, kJobTimeout);
  ASSERT_EQ(redone["status"], "succeeded") << redone.dump(2);
  EXPECT_EQ(redone["input"], job["input"]);
  EXPECT_EQ(client.Get((again + "/burst.tar").c_str())->body, burst_tar);
  const json redone_result = json::parse(client.Get((again + "/result.json").c_str())->body);
  EXPECT_NEAR(redone_result["calibration"]["fx"].get<double>(),
              result["calibration"]["fx"].get<double>(),
              1e-6 * result["calibration"]["fx"].get<double>());
  EXPECT_EQ(daemon->Stop(SIGTERM), 0) << daemon->Log();
}

// "frames": "auto": the job keeps the frames nearest the trigger that its
// parallax needs and says what it took and why; a camera that only turns
// gets "move the camera a little" instead of a depth map. A capture of a
// fixed length that turned without moving keeps its result, and its depth
// map is unreliable with the same advice, at the same configured bound.
TEST_F(DfsmdTest, AutoFramesTakeWhatTheParallaxNeedsOrAskForMotion) {
  // One capture (an "auto" one of 12 frames unless `request` says otherwise)
  // from a dfsmd replaying a burst that moved `baseline` metres while it
  // turned 1 deg: the finished job, and its result.json where it succeeded.
  // Each length tried is one sparse stage more than a fixed capture's job, so
  // the wait is longer (the thread sanitizer's build runs this test too).
  const auto capture =
      [&](const std::string& name, double baseline, const std::vector<std::string>& extra,
          const std::string& request = R"({"frames":"auto","max_frames":12,"when":"next"})") {
        SynthOptions options;
        options.width = 320;
        options.height = 240;
        options.frames = 12;
        options.seed = 5;
        options.supersampling = 1;
        options.baseline = baseline;
        options.rotation_deg = 1.0;
        WriteSynthBurst(dir_ / name, SynthesizeBurst(options));
        std::vector<std::string> args = {"--capture.source",  "replay:" + (dir_ / name).string(),
                                         "--jobs.state_dir",  (dir_ / ("state-" + name)).string(),
                                         "--pipeline.planes", "32"};
        args.insert(args.end(), extra.begin(), extra.end());
        DfsmdProcess daemon(DFSMD_BINARY, args, dir_ / (name + ".log"));
        EXPECT_TRUE(daemon.ok()) << daemon.Log();
        httplib::Client client = daemon.Client();
        const std::string location =
            Accepted(client.Post("/api/v1/captures", request, "application/json"));
        const json job = AwaitFinished(client, location, 3 * kJobTimeout);
        const auto result = client.Get((location + "/result.json").c_str());
        return std::make_pair(job,
                              result && result->status == 200 ? json::parse(result->body) : json());
      };
  const auto [moving, result] =
      capture("moving", 0.02,
              {"--pipeline.auto_parallax_px", "0.3", "--pipeline.still_parallax_px", "0.1"});
  ASSERT_EQ(moving["status"], "succeeded") << moving.dump(2);
  EXPECT_EQ(moving["options"]["frames"], "auto");
  EXPECT_EQ(moving["options"]["max_frames"], 12);
  const json& taken = result.at("auto_frames");
  EXPECT_EQ(taken, moving["input"]["auto_frames"]);
  EXPECT_EQ(taken["reason"], "parallax reached") << taken.dump();
  EXPECT_EQ(taken["frames"], 10);
  EXPECT_EQ(taken["of"], 12);
  EXPECT_EQ(result["poses"].size(), 10u);

  const json turning = capture("turning", 0.0, {}).first;
  ASSERT_EQ(turning["status"], "failed") << turning.dump(2);
  EXPECT_NE(turning["error"].get<std::string>().find("move the camera a little"), std::string::npos)
      << turning.dump(2);
  EXPECT_EQ(turning["input"]["auto_frames"]["reason"], "too still");

  const auto [fixed, fixed_result] =
      capture("turning-fixed", 0.0, {"--pipeline.still_parallax_px", "0.2"},
              R"({"frames":10,"when":"next"})");
  ASSERT_EQ(fixed["status"], "succeeded") << fixed.dump(2);
  EXPECT_EQ(fixed_result["depth_verdict"]["quality"], "unreliable") << fixed_result.dump(2);
  EXPECT_LT(fixed_result["parallax"]["median_px"].get<double>(), 0.2);
  const json& warnings = fixed_result.at("warnings");
  EXPECT_TRUE(std::any_of(warnings.begin(), warnings.end(), [](const json& warning) {
    const std::string text = warning.get<std::string>();
    return text.rfind("move the camera a little", 0) == 0 &&
           text.find("depth needs 0.20 px") != std::string::npos;
  })) << warnings.dump(2);
}

TEST_F(DfsmdTest, UploadedBurstIsProcessedTheSameWay) {
  auto daemon = Start();
  httplib::Client client = daemon->Client();
  // Our writer (top level) and GNU tar (one top-level directory) both work,
  // the latter in tar's default format with names over ustar's 100 characters
  // (GNU long-name headers).
  const std::string ours = service::WriteTar(service::CollectFiles(root_ / "burst"));
  const std::string location =
      Accepted(client.Post("/api/v1/jobs?keep_burst=false", ours, "application/x-tar"));
  const std::string long_top(120, 'b');
  fs::copy(root_ / "burst", dir_ / long_top, fs::copy_options::recursive);
  ASSERT_EQ(
      std::system(("tar -C " + dir_.string() + " -cf " + (dir_ / "b.tar").string() + " " + long_top)
                      .c_str()),
      0);
  const std::string gnu = ReadFileToString(dir_ / "b.tar");
  const std::string second =
      Accepted(client.Post("/api/v1/jobs?frames=8", gnu, "application/x-tar"));
  const json job = AwaitFinished(client, location, kJobTimeout);
  ASSERT_EQ(job["status"], "succeeded") << job.dump(2);
  EXPECT_EQ(job["origin"], "upload");
  EXPECT_FALSE(job["has_burst"]);
  ExpectProblem(client.Get((location + "/burst.tar").c_str()), 410);
  const DepthEvaluation score = ScoreDepth(client, location);
  EXPECT_LT(score.abs_rel, 0.10) << json(ToJson(score)).dump();
  const json other = AwaitFinished(client, second, kJobTimeout);
  EXPECT_EQ(other["status"], "succeeded") << other.dump(2);
  EXPECT_EQ(other["input"]["frames"], 8);
  // Every finished job says how far its calibration can be trusted, and what
  // the result cannot vouch for.
  EXPECT_TRUE(other["warnings"].is_array()) << other.dump(2);
  const std::string quality = other.value("calibration_quality", "");
  EXPECT_TRUE(quality == "reliable" || quality == "uncertain" || quality == "degenerate")
      << other.dump(2);
  const json calibration = json::parse(client.Get("/api/v1/calibration")->body);
  EXPECT_TRUE(calibration["calibration"]["uncertainty"].is_object()) << calibration.dump(2);
  EXPECT_TRUE(calibration["calibration"]["quality"].is_string()) << calibration.dump(2);

  // A burst with a frame missing: the upload is refused, naming the file.
  std::vector<service::TarFile> files = service::CollectFiles(root_ / "burst");
  files.erase(std::remove_if(files.begin(), files.end(),
                             [](const auto& f) { return f.path == "frames/000003.png"; }),
              files.end());
  auto broken = client.Post("/api/v1/jobs", service::WriteTar(files), "application/x-tar");
  ExpectProblem(broken, 422);
  EXPECT_NE(broken->body.find("000003.png"), std::string::npos) << broken->body;
  EXPECT_EQ(json::parse(client.Get("/api/v1/jobs")->body)["jobs"].size(), 2u);

  // A 200 KB manifest whose width is 100 000 nested arrays killed dfsmd (the
  // error message serialized it recursively): now a problem, and dfsmd lives on.
  const int depth = 100000;
  const std::string nested = R"({"format":"dfsm-burst/1","height":480,"frames":[],"width":)" +
                             std::string(depth, '[') + std::string(depth, ']') + "}";
  auto hostile = client.Post("/api/v1/jobs", service::WriteTar({{"manifest.json", nested}}),
                             "application/x-tar");
  ExpectProblem(hostile, 422);
  EXPECT_NE(hostile->body.find("nested deeper than"), std::string::npos) << hostile->body;
  ASSERT_TRUE(client.Get("/healthz"));
  EXPECT_EQ(client.Get("/healthz")->status, 200);
  EXPECT_EQ(daemon->Stop(SIGTERM), 0);
}

TEST_F(DfsmdTest, FullQueueAnswers503AndBadRequestsAreProblems) {
  auto daemon = Start({"--jobs.queue", "1"});
  httplib::Client client = daemon->Client();
  int accepted = 0, refused = 0;
  std::vector<std::string> locations;
  for (int i = 0; i < 6; ++i) {
    auto result = client.Post("/api/v1/captures", R"({"frames":5})", "application/json");
    ASSERT_TRUE(result);
    if (result->status == 202) {
      ++accepted;
      locations.push_back(result->get_header_value("Location"));
    } else {
      ExpectProblem(result, 503);
      EXPECT_EQ(result->get_header_value("Retry-After"), "5");
      ++refused;
    }
  }
  EXPECT_GE(accepted, 1);
  EXPECT_GE(refused, 3);  // one runs, one waits, the rest are refused
  // A full queue is answered from the request's head, before its body is
  // read: the bodies below are judged once the queue has room.
  for (const std::string& location : locations) AwaitFinished(client, location, kJobTimeout);
  ExpectProblem(client.Post("/api/v1/captures", R"({"frames":"many"})", "application/json"), 400);
  ExpectProblem(client.Post("/api/v1/captures", R"({"frames":500})", "application/json"), 400);
  ExpectProblem(client.Post("/api/v1/captures", "{", "application/json"), 400);
  ExpectProblem(client.Get("/api/v1/jobs/j0000000000000-0000"), 404);
  ExpectProblem(client.Get("/api/v1/jobs/nonsense"), 404);
  ExpectProblem(client.Delete("/api/v1/jobs/nonsense"), 404);
  ExpectProblem(client.Get((locations[0] + "/..%2F..%2Fjob.json").c_str()), 404);
  ExpectProblem(client.Get((locations[0] + "/job.json").c_str()), 404);
  ExpectProblem(client.Get("/api/v1/jobs/..%2F..%2F..%2Fetc%2Fpasswd"), 404);
  EXPECT_EQ(daemon->Stop(SIGTERM), 0);
}

TEST_F(DfsmdTest, KillDuringAJobThenRestartCompletesIt) {
  auto daemon = Start({"--pipeline.planes", "256"});
  httplib::Client client = daemon->Client();
  const std::string first = Accepted(
      client.Post("/api/v1/captures", R"({"frames":10,"when":"next"})", "application/json"));
  ASSERT_EQ(AwaitFinished(client, first, kJobTimeout)["status"], "succeeded");
  const std::string depth_before = client.Get((first + "/depth.tiff").c_str())->body;

  const std::string second = Accepted(
      client.Post("/api/v1/captures", R"({"frames":10,"when":"next"})", "application/json"));
  // Kill it mid-pipeline, once its burst is stored (the pipeline starts on
  // the frames in memory while they are written beside it).
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  json seen = json::object();
  while (std::chrono::steady_clock::now() < deadline &&
         !(seen.value("status", "") == "processing" && seen.value("has_burst", false))) {
    seen = json::parse(client.Get(second.c_str())->body);
  }
  ASSERT_EQ(seen["status"], "processing") << seen.dump(2);
  ASSERT_TRUE(seen["has_burst"]) << seen.dump(2);
  EXPECT_EQ(daemon->Stop(SIGKILL), 128 + SIGKILL);
  daemon.reset();

  auto restarted = Start({"--pipeline.planes", "256"});
  httplib::Client again = restarted->Client();
  const json job = AwaitFinished(again, second, kJobTimeout);
  EXPECT_EQ(job["status"], "succeeded") << job.dump(2);
  EXPECT_EQ(job["attempts"], 2);
  EXPECT_EQ(again.Get((first + "/depth.tiff").c_str())->body, depth_before);
  EXPECT_EQ(json::parse(again.Get(first.c_str())->body)["status"], "succeeded");
  EXPECT_NE(restarted->Log().find("re-queueing job"), std::string::npos);
  EXPECT_EQ(restarted->Stop(SIGTERM), 0);
}

TEST_F(DfsmdTest, SigtermFinishesTheRunningJobAndExitsCleanly) {
  ExpectStopFinishesTheRunningJob(SIGTERM, "SIGTERM");
}

// SIGHUP ended dfsmd at once (exit 129) with the running job cut off; it is a
// stop like SIGTERM (dfsmd reads its configuration once).
TEST_F(DfsmdTest, SighupStopsCleanlyLikeSigterm) {
  ExpectStopFinishesTheRunningJob(SIGHUP, "SIGHUP");
}

// A second dfsmd on the same state directory re-queued the first one's running
// job and processed it too, before it found the port taken. The state
// directory's lock refuses it before it reads anything.
TEST_F(DfsmdTest, ASecondDaemonOnTheSameStateDirectoryIsRefused) {
  auto daemon = Start({"--pipeline.planes", "256"});
  httplib::Client client = daemon->Client();
  const std::string location = CaptureTakenByAWorker(client);
  EXPECT_EQ(RunDfsmd(DFSMD_BINARY, Args({"--server.port", "0"}), dir_ / "second.log"), 1);
  const std::string second = ReadFileToString(dir_ / "second.log");
  EXPECT_NE(second.find("another dfsmd (pid " + std::to_string(daemon->pid()) + ")"),
            std::string::npos)
      << second;
  EXPECT_EQ(second.find("re-queueing"), std::string::npos) << second;
  const json job = AwaitFinished(client, location, kJobTimeout);
  EXPECT_EQ(job["status"], "succeeded");
  EXPECT_EQ(job["attempts"], 1);
  EXPECT_EQ(daemon->Stop(SIGTERM), 0);
  // Once it has gone, the directory is free again.
  auto next = Start();
  EXPECT_EQ(json::parse(next->Client().Get(location.c_str())->body)["attempts"], 1);
  EXPECT_EQ(next->Stop(SIGTERM), 0);
}

TEST_F(DfsmdTest, InvalidConfigurationExits78AndBusyPortFails) {
  EXPECT_EQ(RunDfsmd(DFSMD_BINARY, {"--server.port", "99999"}, dir_ / "bad.log"), 78);
  EXPECT_NE(ReadFileToString(dir_ / "bad.log").find("server.port: must be in [0, 65535]"),
            std::string::npos);
  std::ofstream(dir_ / "bad.toml") << "[pipeline]\ninit = \"rank3\"\n";
  EXPECT_EQ(RunDfsmd(DFSMD_BINARY, {"--config", (dir_ / "bad.toml").string()}, dir_ / "bad2.log"),
            78);
  EXPECT_NE(ReadFileToString(dir_ / "bad2.log").find("pipeline.init"), std::string::npos);

  // A second daemon on a taken port must fail, not share it (no SO_REUSEPORT).
  auto daemon = Start();
  std::vector<std::string> args = Args();
  args[3] = (dir_ / "state2").string();
  args.insert(args.end(), {"--server.port", std::to_string(daemon->port())});
  EXPECT_EQ(RunDfsmd(DFSMD_BINARY, args, dir_ / "second.log"), 1);
  EXPECT_NE(ReadFileToString(dir_ / "second.log").find("cannot listen"), std::string::npos);
  EXPECT_EQ(daemon->Stop(SIGTERM), 0);
}

// systemd's side of Type=notify: a datagram socket collecting the messages.
class NotifySocket {
 public:
  explicit NotifySocket(const fs::path& path) : path_(path) {
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    std::snprintf(address.sun_path, sizeof(address.sun_path), "%s", path.c_str());
    ::bind(fd_, reinterpret_cast<sockaddr*>(&address), sizeof(address));
    timeval timeout{0, 100000};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof(timeout));
  }
  ~NotifySocket() { ::close(fd_); }
  // Every message received within `duration`, concatenated.
  std::string Collect(std::chrono::milliseconds duration) {
    std::string all;
    const auto deadline = std::chrono::steady_clock::now() + duration;
    char buffer[4096];
    while (std::chrono::steady_clock::now() < deadline) {
      const ssize_t n = ::recv(fd_, buffer, sizeof(buffer), 0);
      if (n > 0) all += std::string(buffer, static_cast<size_t>(n)) + "\n";
    }
    return all;
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
  int fd_ = -1;
};

TEST_F(DfsmdTest, NotifiesReadinessAndPingsTheWatchdogWhileCaptureRuns) {
  NotifySocket socket(dir_ / "notify");
  const std::map<std::string, std::string> env = {{"NOTIFY_SOCKET", socket.path().string()},
                                                  {"WATCHDOG_USEC", "200000"}};
  {
    DfsmdProcess daemon(DFSMD_BINARY, Args(), dir_ / "dfsmd.log", env);
    ASSERT_TRUE(daemon.ok()) << daemon.Log();
    const std::string messages = socket.Collect(std::chrono::milliseconds(600));
    EXPECT_NE(messages.find("READY=1"), std::string::npos) << messages;
    EXPECT_NE(messages.find("WATCHDOG=1"), std::string::npos) << messages;
    EXPECT_EQ(daemon.Stop(SIGTERM), 0);
    EXPECT_NE(socket.Collect(std::chrono::milliseconds(200)).find("STOPPING=1"), std::string::npos);
  }
  // A device that never delivers a frame: ready (the API serves and says why
  // it is not ready), but no watchdog pings, so systemd would restart it.
  DfsmdProcess stuck(
      DFSMD_BINARY,
      {"--capture.source", "v4l2:/dev/dfsmd-test-no-such-camera", "--capture.frame_timeout_ms",
       "200", "--capture.stall_timeout_ms", "300", "--jobs.state_dir", (dir_ / "state2").string()},
      dir_ / "stuck.log", env, /*wait_streaming=*/false);
  ASSERT_TRUE(stuck.ok()) << stuck.Log();
  const std::string messages = socket.Collect(std::chrono::milliseconds(800));
  EXPECT_NE(messages.find("READY=1"), std::string::npos) << messages << stuck.Log();
  EXPECT_EQ(messages.find("WATCHDOG=1"), std::string::npos) << messages;
  httplib::Client client = stuck.Client();
  ExpectProblem(client.Get("/readyz"), 503);
  ExpectProblem(client.Post("/api/v1/captures", "", "application/json"), 503);
  EXPECT_EQ(stuck.Stop(SIGTERM), 0) << stuck.Log();
}

}  // namespace
}  // namespace dfsm::test
