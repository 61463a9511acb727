#include "api/routes_test_harness.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "core/io/file_util.h"

namespace dfsm::api {

namespace fs = std::filesystem;

RoutesTestHarness::RoutesTestHarness(const std::string& name, const service::DaemonConfig& config,
                                     const service::TarLimits& tar_limits,
                                     const service::BurstLimits& burst_limits)
    : dir_(fs::temp_directory_path() / (name + "-" + std::to_string(::getpid()))), config_(config) {
  fs::remove_all(dir_);
  store_ = std::make_unique<service::JobStore>(dir_);
  scheduler_ = std::make_unique<service::JobScheduler>(
      1, config_.jobs.queue, [](const std::string&, std::shared_ptr<const Burst>) {});
  intake_ = std::make_unique<service::JobIntake>(store_.get(), scheduler_.get(), nullptr, &metrics_,
                                                 tar_limits, burst_limits);
  const ApiContext context{&config_,      store_.get(), scheduler_.get(),
                           intake_.get(), nullptr,      &metrics_};
  server_ = std::make_unique<HttpServer>(config_.server);
  RegisterRoutes(context, server_.get());
  port_ = server_->Bind();
  server_->Start();
}

RoutesTestHarness::~RoutesTestHarness() {
  server_->Stop();
  scheduler_->Shutdown();
  std::error_code ignored;
  fs::remove_all(dir_, ignored);
}

std::string RoutesTestHarness::AddJob(service::JobStatus status) {
  const fs::path burst = store_->NewStagingDir() / "burst";
  fs::create_directories(burst);
  WriteFileAtomically(burst / "manifest.json", "{}");
  service::Job job = store_->Create("upload", {}, burst, {});
  job.status = status;
  store_->Update(job);
  return job.id;
}

std::string ExpectProblem(const httplib::Result& result, int status) {
  EXPECT_TRUE(result);
  if (!result) return "";
  EXPECT_EQ(result->status, status) << result->body;
  EXPECT_EQ(result->get_header_value("Content-Type"), "application/problem+json");
  const nlohmann::json body = nlohmann::json::parse(result->body, nullptr, false);
  EXPECT_FALSE(body.is_discarded()) << result->body;
  if (body.is_discarded()) return "";
  EXPECT_EQ(body.value("status", 0), status);
  EXPECT_FALSE(body.value("title", "").empty());
  return body.value("detail", "");
}

}  // namespace dfsm::api
