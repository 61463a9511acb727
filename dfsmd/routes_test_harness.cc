#include "dfsmd/routes_test_harness.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "core/io/file_util.h"

namespace dfsm::api {

namespace fs = std::filesystem;

RoutesTestHarness::RoutesTestHarness(const std::string& name, service::DaemonConfig config)
    : dir_(fs::temp_directory_path() / (name + "-" + std::to_string(::getpid()))) {
  fs::remove_all(dir_);
  config.jobs.state_dir = dir_;
  daemon::AssembleOptions options;
  options.camera = false;
  options.recover = false;
  options.start_workers = false;
  parts_ = daemon::Assemble(config, options);
  port_ = parts_->http->Bind();
  parts_->http->Start();
}

RoutesTestHarness::~RoutesTestHarness() {
  parts_.reset();
  std::error_code ignored;
  fs::remove_all(dir_, ignored);
}

std::string RoutesTestHarness::AddJob(service::JobStatus status) {
  const fs::path burst = parts_->store->NewStagingDir() / "burst";
  fs::create_directories(burst);
  WriteFileAtomically(burst / "manifest.json", "{}");
  service::Job job = parts_->store->Create("upload", {}, burst, {});
  job.status = status;
  parts_->store->Update(job);
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
