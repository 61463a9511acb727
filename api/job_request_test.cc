#include "api/job_request.h"

#include <gtest/gtest.h>

namespace dfsm::api {
namespace {

std::string ErrorOf(const std::function<void()>& body) {
  try {
    body();
  } catch (const RequestError& e) {
    return e.what();
  }
  return "";
}

TEST(JobRequestTest, EmptyBodyGivesTheConfiguredDefaults) {
  service::DaemonConfig config;
  config.pipeline.planes = 48;
  config.jobs.keep_burst = false;
  const service::JobOptions options = ParseCaptureRequest("  \n", config);
  EXPECT_EQ(options.frames, 10);
  EXPECT_EQ(options.when, service::BurstWhen::kLast);
  EXPECT_EQ(options.init, InitMode::kRankOne);
  EXPECT_EQ(options.planes, 48);
  EXPECT_FALSE(options.keep_burst);
}

TEST(JobRequestTest, TheConfiguredChoicesAreTheDefaults) {
  service::DaemonConfig config;
  config.pipeline.when = service::BurstWhen::kNext;
  config.pipeline.init = InitMode::kNaive;
  const service::JobOptions options = ParseCaptureRequest("", config);
  EXPECT_EQ(options.when, service::BurstWhen::kNext);
  EXPECT_EQ(options.init, InitMode::kNaive);
  EXPECT_EQ(ParseCaptureRequest(R"({"when":"last","init":"rank1"})", config).when,
            service::BurstWhen::kLast);
  EXPECT_EQ(ParseUploadQuery({}, config).init, InitMode::kNaive);
}

TEST(JobRequestTest, BodyOverridesEachField) {
  const service::JobOptions options = ParseCaptureRequest(
      R"({"frames":12,"when":"next","planes":64,"grid":40,"init":"naive","rolling_shutter":"0.6","dense":false,"keep_burst":false})",
      service::DaemonConfig());
  EXPECT_EQ(options.frames, 12);
  EXPECT_EQ(options.when, service::BurstWhen::kNext);
  EXPECT_EQ(options.planes, 64);
  EXPECT_EQ(options.grid, 40);
  EXPECT_EQ(options.init, InitMode::kNaive);
  EXPECT_EQ(options.rolling_shutter, "0.6");
  EXPECT_FALSE(options.dense);
  EXPECT_FALSE(options.keep_burst);
}

TEST(JobRequestTest, BadBodiesNameTheProblem) {
  const service::DaemonConfig config;
  const auto error = [&](const std::string& body) {
    return ErrorOf([&] { ParseCaptureRequest(body, config); });
  };
  EXPECT_NE(error("{\"frames\":").find("not valid JSON"), std::string::npos);
  EXPECT_EQ(error("[1]"), "the body must be a JSON object");
  EXPECT_EQ(error(R"({"frames":"ten"})"), "'frames' must be an integer or \"auto\"");
  EXPECT_EQ(error(R"({"frames":2})"), "'frames' must be in [3, 64], got 2");
  EXPECT_EQ(error(R"({"frames":65})"), "'frames' must be in [3, 64], got 65");
  EXPECT_EQ(error(R"({"when":"soon"})"), "'when' must be \"last\" or \"next\", got \"soon\"");
  EXPECT_EQ(error(R"({"init":"rank2"})"), "'init' must be \"rank1\" or \"naive\", got \"rank2\"");
  EXPECT_EQ(error(R"({"planes":1})"), "'planes' must be in [2, 1024], got 1");
  EXPECT_NE(error(R"({"rolling_shutter":"1.5"})")
                .find("'rolling_shutter': the rolling shutter readout must be in [0, 1]"),
            std::string::npos);
  EXPECT_NE(error(R"({"rolling_shutter":"rolling"})").find("\"global\", \"estimate\" or a readout"),
            std::string::npos);
  EXPECT_EQ(error(R"({"dense":"yes"})"), "'dense' must be true or false");
  EXPECT_NE(error(R"({"frame":10})").find("unknown field 'frame'"), std::string::npos);
}

// "frames": "auto" takes max_frames (the configured one by default) and
// keeps as many as the parallax needs; max_frames means nothing without it.
TEST(JobRequestTest, AutoFramesTakeAtMostMaxFrames) {
  service::DaemonConfig config;
  config.pipeline.max_frames = 24;
  const service::JobOptions configured = ParseCaptureRequest(R"({"frames":"auto"})", config);
  EXPECT_TRUE(configured.auto_frames);
  EXPECT_EQ(configured.frames, 24);
  const service::JobOptions asked =
      ParseCaptureRequest(R"({"max_frames":40,"frames":"auto"})", config);
  EXPECT_TRUE(asked.auto_frames);
  EXPECT_EQ(asked.frames, 40);
  EXPECT_FALSE(ParseCaptureRequest(R"({"frames":12})", config).auto_frames);
  config.pipeline.max_frames = 100;  // more than the ring (64) holds
  EXPECT_EQ(ParseCaptureRequest(R"({"frames":"auto"})", config).frames, 64);
  config.pipeline.max_frames = 24;
  const auto error = [&](const std::string& body) {
    return ErrorOf([&] { ParseCaptureRequest(body, config); });
  };
  EXPECT_EQ(error(R"({"max_frames":20})"), "'max_frames' applies to \"frames\": \"auto\" only");
  EXPECT_EQ(error(R"({"frames":12,"max_frames":20})"),
            "'max_frames' applies to \"frames\": \"auto\" only");
  EXPECT_EQ(error(R"({"frames":"auto","max_frames":65})"),
            "'max_frames' must be in [3, 64], got 65");
  EXPECT_NE(ErrorOf([&] {
              ParseUploadQuery({{"max_frames", "20"}}, config);
            }).find("unknown field 'max_frames'"),
            std::string::npos);
  EXPECT_EQ(ErrorOf([&] {
              ParseUploadQuery({{"frames", "auto"}}, config);
            }),
            "'frames' must be an integer, got 'auto'");
}

TEST(JobRequestTest, UploadQueryIsTextAndHasNoWhen) {
  const service::DaemonConfig config;
  const service::JobOptions all = ParseUploadQuery({}, config);
  EXPECT_EQ(all.frames, 0);  // every frame of the upload
  EXPECT_FALSE(all.when.has_value());
  const service::JobOptions options =
      ParseUploadQuery({{"frames", "8"}, {"init", "naive"}, {"keep_burst", "false"}}, config);
  EXPECT_EQ(options.frames, 8);
  EXPECT_EQ(options.init, InitMode::kNaive);
  EXPECT_FALSE(options.keep_burst);
  EXPECT_EQ(ErrorOf([&] {
              ParseUploadQuery({{"planes", "many"}}, config);
            }),
            "'planes' must be an integer, got 'many'");
  EXPECT_NE(ErrorOf([&] {
              ParseUploadQuery({{"when", "next"}}, config);
            }).find("unknown field 'when'"),
            std::string::npos);
  EXPECT_EQ(ErrorOf([&] {
              ParseUploadQuery({{"dense", "1"}, {"dense", "0"}}, config);
            }),
            "'dense' is given more than once");
}

// The upload's cap on frames is limits.max_burst_frames, not a number of its own.
TEST(JobRequestTest, UploadFramesFollowTheBurstFrameLimit) {
  service::DaemonConfig config;
  config.limits.max_burst_frames = 5000;
  EXPECT_EQ(ParseUploadQuery({{"frames", "4000"}}, config).frames, 4000);
  config.limits.max_burst_frames = 20;
  EXPECT_EQ(ErrorOf([&] {
              ParseUploadQuery({{"frames", "21"}}, config);
            }),
            "'frames' must be in [3, 20], got 21");
  EXPECT_EQ(ParseUploadQuery({{"frames", "0"}}, config).frames, 0);  // all of them
}

TEST(JobRequestTest, ListQuery) {
  const ListQuery query = ParseListQuery({{"limit", "5"}, {"status", "failed"}});
  EXPECT_EQ(query.limit, 5);
  EXPECT_EQ(query.status, "failed");
  EXPECT_EQ(ErrorOf([] {
              ParseListQuery({{"limit", "0"}});
            }),
            "'limit' must be in [1, 1000], got 0");
  EXPECT_EQ(ErrorOf([] {
              ParseListQuery({{"after", "../x"}});
            }),
            "'after' is not a job id: '../x'");
  EXPECT_NE(ErrorOf([] {
              ParseListQuery({{"status", "done"}});
            }).find("'status' must be"),
            std::string::npos);
  EXPECT_NE(ErrorOf([] {
              ParseListQuery({{"page", "2"}});
            }).find("unknown query parameter 'page'"),
            std::string::npos);
}

}  // namespace
}  // namespace dfsm::api
