// The routes on a real server and store, without a capture source: listing,
// pagination, deletion, problem+json for every kind of bad request, and the
// OpenAPI document naming every route.
#include "api/routes.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include "api/www_files.h"
#include "core/io/file_util.h"
#include "dfsmd/routes_test_harness.h"

namespace dfsm::api {
namespace {

namespace fs = std::filesystem;

class RoutesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    service::DaemonConfig config;
    config.server.port = 0;
    config.server.max_body_bytes = 64 * 1024;
    config.jobs.queue = 2;
    routes_ = std::make_unique<RoutesTestHarness>("routes-test", config);
    client_ = std::make_unique<httplib::Client>("127.0.0.1", routes_->port());
  }

  std::unique_ptr<RoutesTestHarness> routes_;
  std::unique_ptr<httplib::Client> client_;
};

TEST_F(RoutesTest, ListsNewestFirstInPages) {
  std::vector<std::string> ids;
  for (int i = 0; i < 5; ++i) ids.push_back(routes_->AddJob(service::JobStatus::kFailed));
  auto page = client_->Get("/api/v1/jobs?limit=2");
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
  nlohmann::json body = nlohmann::json::parse(page->body);
  ASSERT_EQ(body["jobs"].size(), 2u);
  EXPECT_EQ(body["jobs"][0]["id"], ids[4]);
  EXPECT_EQ(body["jobs"][1]["id"], ids[3]);
  std::vector<std::string> seen;
  std::string next = "/api/v1/jobs?limit=2";
  while (!next.empty()) {
    page = client_->Get(next.c_str());
    body = nlohmann::json::parse(page->body);
    for (const auto& job : body["jobs"]) seen.push_back(job["id"]);
    next = body["next"].is_null() ? "" : body["next"].get<std::string>();
  }
  EXPECT_EQ(seen, (std::vector<std::string>{ids[4], ids[3], ids[2], ids[1], ids[0]}));
  ExpectProblem(client_->Get("/api/v1/jobs?limit=none"), 400);
}

TEST_F(RoutesTest, UnknownJobsFilesAndPathTricksAreProblems) {
  const std::string id = routes_->AddJob(service::JobStatus::kQueued);
  EXPECT_NE(
      ExpectProblem(client_->Get("/api/v1/jobs/j0000000000000-0000"), 404).find("there is no job"),
      std::string::npos);
  EXPECT_NE(ExpectProblem(client_->Get("/api/v1/jobs/..%2E"), 404).find("not a job id"),
            std::string::npos);
  ExpectProblem(client_->Get("/api/v1/jobs/..%2F..%2Fetc"), 404);
  EXPECT_NE(ExpectProblem(client_->Get(("/api/v1/jobs/" + id + "/job.json").c_str()), 404)
                .find("not a job file"),
            std::string::npos);
  ExpectProblem(client_->Get(("/api/v1/jobs/" + id + "/..%2Fjob.json").c_str()), 404);
  ExpectProblem(client_->Get(("/api/v1/jobs/" + id + "/../../jobs").c_str()), 404);
  ExpectProblem(client_->Get(("/api/v1/jobs/" + id + "/result.json").c_str()), 409);
  ExpectProblem(client_->Get("/api/v1/nothing"), 404);
  // No calibration before a job has succeeded is a state, not a problem.
  const auto calibration = client_->Get("/api/v1/calibration");
  ASSERT_TRUE(calibration);
  EXPECT_EQ(calibration->status, 200);
  EXPECT_TRUE(nlohmann::json::parse(calibration->body)["calibration"].is_null())
      << calibration->body;
  ExpectProblem(client_->Get("/api/v1/snapshot.jpg"), 503);
  ExpectProblem(client_->Get("/api/v1/snapshot.jpg?width=8"), 400);
  EXPECT_NE(ExpectProblem(client_->Get("/readyz"), 503).find("no capture source"),
            std::string::npos);
  EXPECT_EQ(client_->Get("/healthz")->status, 200);
}

TEST_F(RoutesTest, BadUploadsAreNamed) {
  auto tar = [&](const std::string& body, const std::string& query = "") {
    return client_->Post(("/api/v1/jobs" + query).c_str(), body, "application/x-tar");
  };
  EXPECT_NE(ExpectProblem(tar("not a tar" + std::string(600, ' ')), 422).find("not a tar archive"),
            std::string::npos);
  EXPECT_NE(ExpectProblem(tar(""), 400).find("must be a tar"), std::string::npos);
  EXPECT_NE(ExpectProblem(tar("\x1F\x8B\x08" + std::string(600, '\0')), 422)
                .find("a gzip-compressed archive: upload an uncompressed tar"),
            std::string::npos);
  ExpectProblem(client_->Post("/api/v1/jobs", "{}", "application/json"), 415);
  EXPECT_NE(ExpectProblem(tar("x", "?planes=0"), 400).find("'planes'"), std::string::npos);
  EXPECT_NE(ExpectProblem(tar(std::string(128 * 1024, '\0')), 413).find("max_body_bytes"),
            std::string::npos);
  EXPECT_NE(
      ExpectProblem(client_->Post("/api/v1/captures", "{\"frames\":", "application/json"), 400)
          .find("not valid JSON"),
      std::string::npos);
  // Valid body, but this daemon has no capture source.
  ExpectProblem(client_->Post("/api/v1/captures", "", "application/json"), 503);
  EXPECT_TRUE(routes_->store().List().empty());  // nothing half-made was kept
  EXPECT_TRUE(fs::is_empty(routes_->dir() / "tmp"));
}

TEST_F(RoutesTest, FullQueueAnswers503WithRetryAfter) {
  auto held1 = routes_->scheduler().TryReserve();
  auto held2 = routes_->scheduler().TryReserve();
  const auto result = client_->Post("/api/v1/captures", "", "application/json");
  EXPECT_NE(ExpectProblem(result, 503).find("queue is full"), std::string::npos);
  EXPECT_EQ(result->get_header_value("Retry-After"), "5");
  EXPECT_NE(ExpectProblem(client_->Get("/readyz"), 503).find("queue is full"), std::string::npos);
  const auto metrics = client_->Get("/metrics");
  EXPECT_NE(metrics->body.find("dfsmd_jobs_rejected_total 1"), std::string::npos);
  EXPECT_NE(metrics->body.find("dfsmd_queue_depth 2"), std::string::npos);
}

TEST_F(RoutesTest, DeleteRemovesQueuedAndFinishedJobs) {
  const std::string queued = routes_->AddJob(service::JobStatus::kQueued);
  routes_->scheduler().SubmitRecovered(queued);
  const std::string processing = routes_->AddJob(service::JobStatus::kProcessing);
  const std::string failed = routes_->AddJob(service::JobStatus::kFailed);
  EXPECT_NE(ExpectProblem(client_->Delete(("/api/v1/jobs/" + processing).c_str()), 409)
                .find("being processed"),
            std::string::npos);
  routes_->store().Remove(processing);
  EXPECT_EQ(client_->Delete(("/api/v1/jobs/" + queued).c_str())->status, 204);
  EXPECT_EQ(client_->Delete(("/api/v1/jobs/" + failed).c_str())->status, 204);
  ExpectProblem(client_->Delete(("/api/v1/jobs/" + failed).c_str()), 404);
  EXPECT_TRUE(routes_->store().List().empty());
}

TEST_F(RoutesTest, OpenApiDocumentsEveryRoute) {
  const auto result = client_->Get("/api/v1/openapi.json");
  ASSERT_EQ(result->status, 200);
  const nlohmann::json document = nlohmann::json::parse(result->body);
  EXPECT_EQ(document["openapi"], "3.0.3");
  for (const char* path : {"/api/v1/captures", "/api/v1/jobs", "/api/v1/jobs/{id}",
                           "/api/v1/jobs/{id}/{file}", "/api/v1/calibration", "/api/v1/camera",
                           "/api/v1/snapshot.jpg", "/healthz", "/readyz", "/metrics"}) {
    EXPECT_TRUE(document["paths"].contains(path)) << path;
  }
  EXPECT_EQ(JobFileContentType("depth.tiff"), std::string("image/tiff"));
  EXPECT_EQ(JobFileContentType("../job.json"), nullptr);
}

TEST_F(RoutesTest, JobsCarryTheirProgress) {
  const std::string queued = routes_->AddJob(service::JobStatus::kQueued);
  const std::string failed = routes_->AddJob(service::JobStatus::kFailed);
  const auto job = [&](const std::string& id) {
    return nlohmann::json::parse(client_->Get(("/api/v1/jobs/" + id).c_str())->body);
  };
  EXPECT_EQ(job(queued)["progress"], 0.0);
  EXPECT_EQ(job(failed)["progress"], 1.0);
}

TEST_F(RoutesTest, ServesTheWebPageItWasBuiltWith) {
  const auto index = client_->Get("/");
  ASSERT_TRUE(index);
  if (WwwFiles().empty()) {
    EXPECT_NE(ExpectProblem(index, 404).find("without its web page"), std::string::npos);
    return;
  }
  EXPECT_EQ(index->status, 200);
  EXPECT_EQ(index->get_header_value("Content-Type"), "text/html; charset=utf-8");
  EXPECT_NE(index->get_header_value("Content-Security-Policy").find("default-src 'self'"),
            std::string::npos);
  for (const WwwFile& file : WwwFiles()) {
    const auto served = client_->Get(("/ui/" + file.path).c_str());
    ASSERT_TRUE(served) << file.path;
    EXPECT_EQ(served->status, 200) << file.path;
    EXPECT_EQ(served->body, file.data) << file.path;
  }
  ExpectProblem(client_->Get("/ui/no-such-file.js"), 404);
  ExpectProblem(client_->Get("/ui/../job.json"), 404);
}

TEST_F(RoutesTest, EventsStreamJobChanges) {
  const std::string id = routes_->AddJob(service::JobStatus::kFailed);
  httplib::Client events("127.0.0.1", routes_->port());
  std::string received;
  const auto result = events.Get("/api/v1/events", [&](const char* data, size_t length) {
    received.append(data, length);
    return received.find("\n\n", received.find("event: job")) == std::string::npos;
  });
  EXPECT_NE(received.find("retry: "), std::string::npos) << received;
  EXPECT_NE(received.find("event: job\ndata: {"), std::string::npos) << received;
  EXPECT_NE(received.find(id), std::string::npos) << received;
  EXPECT_NE(received.find("\"progress\":1.0"), std::string::npos) << received;
}

// The watchdog is pinged only while the API answers its own /healthz through
// the listening port: a server that stopped answering (starved, deadlocked,
// or, here, stopped) gets restarted by systemd like a stuck camera.
TEST_F(RoutesTest, TheWatchdogVerdictNamesAnApiThatDoesNotAnswer) {
  EXPECT_EQ(daemon::WatchdogVerdict(routes_->parts()), "");
  routes_->parts().http->Stop();
  const std::string verdict = daemon::WatchdogVerdict(routes_->parts());
  EXPECT_NE(verdict.find("the API does not answer GET /healthz"), std::string::npos) << verdict;
}

TEST(CorsTest, HeadersOnlyWhenConfigured) {
  for (const std::string origin : {"", "https://viewer.example"}) {
    service::DaemonConfig config;
    config.server.port = 0;
    config.server.cors_origin = origin;
    RoutesTestHarness routes("cors-test", config);
    httplib::Client client("127.0.0.1", routes.port());
    const auto result = client.Get("/api/v1/jobs");
    ASSERT_TRUE(result);
    EXPECT_EQ(result->get_header_value("Access-Control-Allow-Origin"), origin);
    const auto preflight = client.Options("/api/v1/captures");
    ASSERT_TRUE(preflight);
    EXPECT_EQ(preflight->status, origin.empty() ? 404 : 204);
  }
}

}  // namespace
}  // namespace dfsm::api
