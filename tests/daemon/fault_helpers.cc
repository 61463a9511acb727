// Eigen before httplib: <resolv.h> (pulled in by httplib) defines a macro
// `_res` that breaks Eigen's headers.
// clang-format off
#include "core/synth/burst_synthesizer.h"
#include "tests/daemon/fault_helpers.h"
// clang-format on

#include <opencv2/imgcodecs.hpp>
#include <vector>

namespace dfsm::test {
namespace {

using nlohmann::json;

cv::Mat Decode(const std::string& body) {
  return cv::imdecode(std::vector<uchar>(body.begin(), body.end()), cv::IMREAD_UNCHANGED);
}

// A binary PLY of ours: the header's vertex count times 15 bytes follow it.
void ExpectCompletePly(const std::string& body, const std::string& what) {
  const size_t end = body.find("end_header\n");
  ASSERT_EQ(body.rfind("ply\nformat binary_little_endian", 0), 0u) << what;
  ASSERT_NE(end, std::string::npos) << what;
  const size_t count_at = body.find("element vertex ");
  ASSERT_NE(count_at, std::string::npos) << what;
  const size_t vertices = std::stoul(body.substr(count_at + 15));
  EXPECT_EQ(body.size(), end + 11 + vertices * 15) << what;
}

}  // namespace

void WriteTestBurst(const std::filesystem::path& dir) {
  SynthOptions options;
  options.width = 320;
  options.height = 240;
  options.frames = 10;
  options.seed = 3;
  WriteSynthBurst(dir, SynthesizeBurst(options));
}

std::string AcceptedLocation(const httplib::Result& result) {
  EXPECT_TRUE(result);
  if (!result) return "";
  EXPECT_EQ(result->status, 202) << result->body;
  if (result->status != 202) return "";
  return result->get_header_value("Location");
}

json AwaitFinished(httplib::Client& client, const std::string& location,
                   std::chrono::seconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  json job;
  while (std::chrono::steady_clock::now() < deadline) {
    auto result = client.Get(location.c_str());
    if (result && result->status == 200) {
      job = json::parse(result->body);
      if (job["status"] == "succeeded" || job["status"] == "failed") return job;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ADD_FAILURE() << "job " << location << " did not finish: " << job.dump();
  return job;
}

int ExpectCompleteResult(httplib::Client& client, const json& job, int width, int height) {
  const std::string id = job.value("id", "");
  const std::string location = "/api/v1/jobs/" + id;
  const std::string status = job.value("status", "");
  if (status == "failed") {
    EXPECT_FALSE(job.value("error", "").empty()) << job.dump();
    return 0;
  }
  if (status != "succeeded") {
    auto early = client.Get((location + "/result.json").c_str());
    EXPECT_TRUE(early && early->status == 409) << id << " is " << status << " yet serves a result";
    return 0;
  }
  int checked = 0;
  const auto result = client.Get((location + "/result.json").c_str());
  EXPECT_TRUE(result && result->status == 200) << id;
  if (!result || result->status != 200) return 0;
  const json parsed = json::parse(result->body, nullptr, /*allow_exceptions=*/false);
  EXPECT_FALSE(parsed.is_discarded()) << id << ": result.json does not parse";
  EXPECT_EQ(parsed.value("status", ""), "ok") << id;
  ++checked;
  for (const auto& link : job["links"]["files"]) {
    const std::string path = link.get<std::string>();
    const std::string file = path.substr(path.rfind('/') + 1);
    if (file == "result.json") continue;
    const auto got = client.Get(path.c_str());
    EXPECT_TRUE(got && got->status == 200) << path;
    if (!got || got->status != 200) continue;
    ++checked;
    const std::string& body = got->body;
    if (file == "depth.tiff") {
      const cv::Mat depth = Decode(body);
      EXPECT_EQ(depth.type(), CV_32FC1) << path;
      EXPECT_EQ(depth.size(), cv::Size(width, height)) << path;
    } else if (file.size() > 4 && file.substr(file.size() - 4) == ".png") {
      EXPECT_FALSE(Decode(body).empty()) << path << ": " << body.size() << " bytes do not decode";
    } else if (file.size() > 4 && file.substr(file.size() - 4) == ".ply") {
      ExpectCompletePly(body, path);
    } else if (file == "calibration.json") {
      EXPECT_FALSE(json::parse(body, nullptr, false).is_discarded()) << path;
    } else if (file == "calibration.yaml") {
      EXPECT_EQ(body.rfind("%YAML", 0), 0u) << path;
    }
  }
  return checked;
}

}  // namespace dfsm::test
