// The capture device goes away under the REST API and comes back: the real
// routes, job store, intake and streaming capture service over the in-memory
// V4L2 driver (a real device is unplugged in the VM suite, tests/vm). While
// the device is gone, a trigger answers 503 naming the cause and /readyz fails
// saying why; when it returns, both recover without a restart.
#include <gtest/gtest.h>
#include <unistd.h>

#include <iostream>

#include "daemon/capture/fake_v4l2_device.h"
#include "daemon/capture/streaming_service.h"
#include "daemon/capture/v4l2_source.h"
#include "dfsmd/daemon.h"

namespace dfsm::test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using std::chrono::milliseconds;

template <typename Predicate>
bool WaitFor(Predicate done, std::chrono::seconds timeout = std::chrono::seconds(30)) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!done()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(milliseconds(5));
  }
  return true;
}

TEST(DeviceGone, TriggersAnswer503NamingTheCauseAndReadinessRecovers) {
  const fs::path dir =
      fs::temp_directory_path() / ("device-gone-test-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  auto driver = std::make_shared<capture::FakeV4l2Driver>();
  capture::CaptureConfig capture_config;
  capture_config.source = "v4l2:/dev/video-fake";
  capture_config.ring_frames = 256;  // the fake driver is unpaced: slack for slow readers
  capture_config.frame_timeout = milliseconds(500);
  capture_config.reconnect_backoff = milliseconds(20);
  capture::V4l2Source::Options source_options;
  source_options.path = "/dev/video-fake";
  source_options.by_id_dir = "/nonexistent";
  auto capture = std::make_shared<capture::StreamingCaptureService>(
      capture_config,
      std::make_unique<capture::V4l2Source>(source_options, capture::MakeFakeV4l2Device(driver)));

  service::DaemonConfig config;
  config.server.port = 0;
  config.jobs.queue = 4;
  config.jobs.state_dir = dir;
  daemon::AssembleOptions options;
  options.capture = capture;
  options.recover = false;
  options.start_workers = false;  // accepted jobs stay queued; this test is about intake
  std::unique_ptr<daemon::Parts> parts = daemon::Assemble(config, options);
  httplib::Client client("127.0.0.1", parts->http->Bind());
  client.set_read_timeout(std::chrono::seconds(30));
  parts->http->Start();
  const auto trigger = [&] {
    return client.Post("/api/v1/captures", R"({"frames":5,"when":"next"})", "application/json");
  };

  ASSERT_TRUE(WaitFor([&] { return capture->Status().streaming; }));
  EXPECT_EQ(client.Get("/readyz")->status, 200);
  EXPECT_EQ(trigger()->status, 202);

  // Unplugged, and it stays away until the test plugs it back.
  {
    std::lock_guard<std::mutex> lock(driver->mutex);
    driver->unplugged_open_failures = 1 << 30;
    driver->faults = {capture::FakeFault::kUnplug};
  }
  ASSERT_TRUE(WaitFor([&] { return !capture->Status().streaming; }));
  const auto refused = trigger();
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->status, 503) << refused->body;
  EXPECT_EQ(refused->get_header_value("Retry-After"), "1");
  const std::string detail = json::parse(refused->body).value("detail", "");
  std::cout << "trigger while unplugged: " << refused->status << " " << detail << "\n";
  EXPECT_NE(detail.find("capture device gone"), std::string::npos) << detail;
  EXPECT_NE(detail.find("/dev/video-fake"), std::string::npos) << detail;
  const auto ready = client.Get("/readyz");
  EXPECT_EQ(ready->status, 503);
  const std::string why = json::parse(ready->body).value("detail", "");
  std::cout << "/readyz while unplugged: " << ready->status << " " << why << "\n";
  EXPECT_NE(why.find("capture is not streaming"), std::string::npos) << why;
  EXPECT_NE(why.find("/dev/video-fake"), std::string::npos) << why;
  EXPECT_EQ(client.Get("/healthz")->status, 200);  // the process itself is fine
  const json camera = json::parse(client.Get("/api/v1/camera")->body);
  EXPECT_FALSE(camera["streaming"].get<bool>());
  EXPECT_EQ(json::parse(client.Get("/api/v1/jobs")->body)["jobs"].size(), 1u);

  // Plugged back in: the next reopen finds it.
  {
    std::lock_guard<std::mutex> lock(driver->mutex);
    driver->unplugged_open_failures = 0;
  }
  ASSERT_TRUE(WaitFor([&] { return capture->Status().streaming; }));
  EXPECT_TRUE(WaitFor([&] { return client.Get("/readyz")->status == 200; }));
  EXPECT_EQ(trigger()->status, 202);
  EXPECT_GE(capture->Status().reconnects, 1u);
  std::cout << "recovered after " << capture->Status().reconnects << " reconnect(s)\n";

  parts.reset();  // stops the server, the capture and the scheduler
  EXPECT_EQ(driver->open_fds, 0);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace dfsm::test
