// The API's security on a real server: the bearer token on every protected
// route (and before an upload's body is read), path tricks on job ids and
// file names, and the body, header and burst limits, each answered with
// problem+json naming the problem.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <map>
#include <opencv2/imgcodecs.hpp>

#include "api/problem.h"
#include "core/io/burst.h"
#include "core/io/file_util.h"
#include "daemon/service/tar_writer.h"
#include "dfsmd/routes_test_harness.h"

namespace dfsm::api {
namespace {

namespace fs = std::filesystem;

constexpr const char* kToken = "0123456789abcdef0123456789abcdef";

// Sends raw bytes and returns what the server answers until it closes the
// connection or stays silent for half a second.
std::string RawExchange(int port, const std::string& bytes) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  std::string answer;
  if (::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0) {
    timeval timeout{0, 500000};
    ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof(timeout));
    size_t sent = 0;
    while (sent < bytes.size()) {
      const ssize_t n = ::send(fd, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
      if (n <= 0) break;
      sent += static_cast<size_t>(n);
    }
    char buffer[4096];
    for (ssize_t n; (n = ::recv(fd, buffer, sizeof(buffer), 0)) > 0;) answer.append(buffer, n);
  }
  ::close(fd);
  return answer;
}

std::string Png(int width, int height) {
  std::vector<unsigned char> bytes;
  cv::imencode(".png", cv::Mat(height, width, CV_8UC1, cv::Scalar(90)), bytes);
  return std::string(bytes.begin(), bytes.end());
}

class SecurityRoutesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    service::DaemonConfig config;
    config.server.port = 0;
    config.server.max_body_bytes = 256 * 1024;
    config.server.token = kToken;
    config.limits.max_upload_entries = 8;
    config.limits.max_frame_pixels = 64 * 64;
    routes_ = std::make_unique<RoutesTestHarness>("security-routes-test", config);
    anonymous_ = std::make_unique<httplib::Client>("127.0.0.1", routes_->port());
    client_ = std::make_unique<httplib::Client>("127.0.0.1", routes_->port());
    client_->set_bearer_token_auth(kToken);
  }

  std::string AddFinishedJob() { return routes_->AddJob(service::JobStatus::kFailed); }

  // A tar of `files` (name -> contents), as GET .../burst.tar writes it.
  static std::string Tar(const std::map<std::string, std::string>& files) {
    const fs::path dir = fs::temp_directory_path() / ("security-tar-" + std::to_string(::getpid()));
    for (const auto& [name, data] : files) {
      fs::create_directories((dir / name).parent_path());
      WriteFileAtomically(dir / name, data);
    }
    service::DirectoryTar tar(dir);
    std::string archive;
    for (std::string piece = tar.Next(); !piece.empty(); piece = tar.Next()) archive += piece;
    fs::remove_all(dir);
    return archive;
  }

  // A tar of a burst of `frames` PNGs, each `png`, declared width x height.
  static std::string BurstTar(int frames, const std::string& png, int width, int height) {
    std::map<std::string, std::string> files;
    nlohmann::json manifest = {{"format", "dfsm-burst/1"}, {"width", width}, {"height", height}};
    for (int i = 0; i < frames; ++i) {
      const std::string name = "frames/" + std::to_string(i) + ".png";
      manifest["frames"].push_back({{"file", name}});
      files["burst/" + name] = png;
    }
    files["burst/manifest.json"] = manifest.dump();
    return Tar(files);
  }

  std::unique_ptr<RoutesTestHarness> routes_;
  std::unique_ptr<httplib::Client> anonymous_, client_;
};

TEST_F(SecurityRoutesTest, EveryProtectedRouteNeedsTheToken) {
  const std::string job = "/api/v1/jobs/" + AddFinishedJob();
  std::vector<httplib::Result> refused;
  refused.push_back(anonymous_->Post("/api/v1/captures", "{}", "application/json"));
  refused.push_back(anonymous_->Post("/api/v1/jobs", "x", "application/x-tar"));
  refused.push_back(anonymous_->Delete(job.c_str()));
  refused.push_back(anonymous_->Get("/api/v1/jobs"));
  refused.push_back(anonymous_->Get(job.c_str()));
  refused.push_back(anonymous_->Get((job + "/result.json").c_str()));
  refused.push_back(anonymous_->Get("/api/v1/calibration"));
  refused.push_back(anonymous_->Get("/api/v1/camera"));
  refused.push_back(anonymous_->Get("/api/v1/snapshot.jpg"));
  refused.push_back(anonymous_->Get("/metrics"));
  refused.push_back(anonymous_->Get("/no/such/route"));
  for (httplib::Result& result : refused) {
    EXPECT_NE(ExpectProblem(result, 401).find("Authorization: Bearer <token>"), std::string::npos);
    EXPECT_EQ(result->get_header_value("WWW-Authenticate"), "Bearer realm=\"dfsmd\"");
  }
  EXPECT_TRUE(routes_->store().Get(job.substr(13)));  // the DELETE did nothing

  httplib::Client wrong("127.0.0.1", routes_->port());
  wrong.set_bearer_token_auth("0123456789abcdef0123456789abcdeX");
  const auto result = wrong.Delete(job.c_str());
  EXPECT_NE(ExpectProblem(result, 401).find("not the one"), std::string::npos);
  EXPECT_EQ(result->get_header_value("WWW-Authenticate"),
            "Bearer realm=\"dfsmd\", error=\"invalid_token\"");
  httplib::Client basic("127.0.0.1", routes_->port());
  basic.set_basic_auth("user", kToken);
  EXPECT_NE(ExpectProblem(basic.Get("/api/v1/jobs"), 401).find("Bearer scheme"), std::string::npos);
  EXPECT_TRUE(routes_->store().Get(job.substr(13)));

  EXPECT_EQ(client_->Get("/api/v1/jobs")->status, 200);
  EXPECT_EQ(client_->Get("/metrics")->status, 200);
  EXPECT_EQ(client_->Delete(job.c_str())->status, 204);
  EXPECT_FALSE(routes_->store().Get(job.substr(13)));
}

TEST_F(SecurityRoutesTest, ProbesAndTheApiDescriptionArePublic) {
  EXPECT_EQ(anonymous_->Get("/healthz")->status, 200);
  EXPECT_EQ(anonymous_->Get("/readyz")->status, 503);  // no capture source here: a real answer
  const auto openapi = anonymous_->Get("/api/v1/openapi.json");
  ASSERT_EQ(openapi->status, 200);
  const nlohmann::json document = nlohmann::json::parse(openapi->body);
  EXPECT_EQ(document["components"]["securitySchemes"]["bearer"]["scheme"], "bearer");
}

TEST_F(SecurityRoutesTest, AnUnauthenticatedUploadIsRefusedBeforeItsBodyIsRead) {
  // Expect: 100-continue: the client gets the 401 instead of "100 Continue"
  // and never sends the 10 MB it announced.
  const std::string answer = RawExchange(
      routes_->port(),
      "POST /api/v1/jobs HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/x-tar\r\n"
      "Content-Length: 10000000\r\nExpect: 100-continue\r\n\r\n");
  EXPECT_EQ(answer.rfind("HTTP/1.1 401", 0), 0u) << answer;
  EXPECT_EQ(answer.find("100 Continue"), std::string::npos) << answer;
  EXPECT_NE(answer.find("WWW-Authenticate: Bearer realm=\"dfsmd\""), std::string::npos);
  // Without Expect, the 401 still comes first, as soon as the headers are in
  // (well before a body over server.max_body_bytes would be refused as 413).
  const std::string direct = RawExchange(
      routes_->port(),
      "POST /api/v1/jobs HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/x-tar\r\n"
      "Content-Length: 10000000\r\n\r\n" +
          std::string(1000, 'x'));
  EXPECT_EQ(direct.rfind("HTTP/1.1 401", 0), 0u) << direct;
  EXPECT_TRUE(routes_->store().List().empty());
}

TEST_F(SecurityRoutesTest, PathTricksNeverReachTheStateDirectory) {
  const std::string id = AddFinishedJob();
  const std::string job = "/api/v1/jobs/" + id;
  // job.json exists in the job's directory, and the state dir holds tmp/.
  for (const std::string& path : std::vector<std::string>{
           job + "/job.json", job + "/..%2Fjob.json", job + "/%2e%2e%2fjob.json",
           job + "/output%2F..%2F..%2Fjob.json", job + "/%2Fetc%2Fpasswd",
           job + "/result.json%00.png", "/api/v1/jobs/" + id + "%2F..%2F" + id + "/result.json",
           "/api/v1/jobs/%2e%2e/jobs", "/api/v1/jobs/..%2F..%2F..%2Fetc%2Fpasswd",
           "/api/v1/jobs/" + id + "%00", "/api/v1/jobs/%2Ftmp",
           "/api/v1/jobs/" + id.substr(0, 18)}) {
    const auto result = client_->Get(path.c_str());
    ASSERT_TRUE(result) << path;
    EXPECT_EQ(result->status, 404) << path << ": " << result->body;
    EXPECT_EQ(result->get_header_value("Content-Type"), "application/problem+json") << path;
  }
  for (const std::string& path :
       std::vector<std::string>{"/api/v1/jobs/..", "/api/v1/jobs/%2e%2e",
                                "/api/v1/jobs/" + id + "%2F..", "/api/v1/jobs/" + id + "%00"}) {
    EXPECT_EQ(client_->Delete(path.c_str())->status, 404) << path;
  }
  EXPECT_TRUE(routes_->store().Get(id));
  EXPECT_TRUE(fs::exists(routes_->dir() / "jobs" / id / "job.json"));
}

TEST_F(SecurityRoutesTest, BodyHeaderAndUriLimitsAreProblems) {
  // Over server.max_body_bytes, announced or chunked.
  EXPECT_NE(
      ExpectProblem(
          client_->Post("/api/v1/jobs", std::string(300 * 1024, 'x'), "application/x-tar"), 413)
          .find("server.max_body_bytes (262144 bytes)"),
      std::string::npos);
  const std::string chunk = std::string(64 * 1024, 'x');
  std::string chunked = "POST /api/v1/jobs HTTP/1.1\r\nHost: 127.0.0.1\r\nAuthorization: Bearer " +
                        std::string(kToken) +
                        "\r\nContent-Type: application/x-tar\r\nTransfer-Encoding: chunked\r\n\r\n";
  for (int i = 0; i < 5; ++i) chunked += "10000\r\n" + chunk + "\r\n";
  chunked += "0\r\n\r\n";
  const std::string answer = RawExchange(routes_->port(), chunked);
  EXPECT_EQ(answer.rfind("HTTP/1.1 413", 0), 0u) << answer.substr(0, 400);
  EXPECT_NE(answer.find("max_body_bytes"), std::string::npos);

  // httplib's compiled-in limits: a header line over 8 KiB is a 400, a request
  // line over 8 KiB a 414; both still problem+json.
  httplib::Headers huge = {{"X-Filler", std::string(9000, 'a')}};
  ExpectProblem(client_->Get("/api/v1/jobs", huge), 400);
  ExpectProblem(client_->Get(("/api/v1/jobs?after=" + std::string(9000, 'a')).c_str()), 414);
}

TEST_F(SecurityRoutesTest, RequestsWithoutContentLengthHaveNoBody) {
  // curl -X POST / -X DELETE send neither Content-Length nor a body; httplib
  // alone would wait for one until its 30 s read timeout.
  const std::string auth = "Authorization: Bearer " + std::string(kToken) + "\r\n";
  const std::string id = AddFinishedJob();
  const auto start = std::chrono::steady_clock::now();
  const std::string deleted =
      RawExchange(routes_->port(),
                  "DELETE /api/v1/jobs/" + id + " HTTP/1.1\r\nHost: 127.0.0.1\r\n" + auth + "\r\n");
  EXPECT_EQ(deleted.rfind("HTTP/1.1 204", 0), 0u) << deleted;
  const std::string captured =
      RawExchange(routes_->port(), "POST /api/v1/captures HTTP/1.1\r\nHost: 127.0.0.1\r\n" + auth +
                                       "Content-Type: application/json\r\n\r\n");
  EXPECT_EQ(captured.rfind("HTTP/1.1 503", 0), 0u) << captured;  // no capture source here
  EXPECT_NE(captured.find("capture-unavailable"), std::string::npos) << captured;
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
  // An unknown path with a chunked body over the limit: refused, not buffered.
  std::string chunked = "POST /no/such/path HTTP/1.1\r\nHost: 127.0.0.1\r\n" + auth +
                        "Transfer-Encoding: chunked\r\n\r\n";
  for (int i = 0; i < 5; ++i) chunked += "10000\r\n" + std::string(0x10000, 'x') + "\r\n";
  const std::string unknown = RawExchange(routes_->port(), chunked + "0\r\n\r\n");
  EXPECT_EQ(unknown.rfind("HTTP/1.1 413", 0), 0u) << unknown.substr(0, 300);
  // Multipart is not a way around the body rules.
  const std::string multipart = RawExchange(
      routes_->port(),
      "POST /api/v1/jobs HTTP/1.1\r\nHost: 127.0.0.1\r\n" + auth +
          "Content-Type: multipart/form-data; boundary=b\r\nContent-Length: 4\r\n\r\n--b\n");
  EXPECT_EQ(multipart.rfind("HTTP/1.1 415", 0), 0u) << multipart;
}

TEST_F(SecurityRoutesTest, UploadLimitsAreNamed) {
  const auto upload = [&](const std::string& tar) {
    return client_->Post("/api/v1/jobs", tar, "application/x-tar");
  };
  // More tar entries than limits.max_upload_entries (8 here).
  EXPECT_NE(ExpectProblem(upload(BurstTar(9, Png(8, 8), 8, 8)), 422).find("more than 8 entries"),
            std::string::npos);
  // A frame over limits.max_frame_pixels (64x64 here).
  EXPECT_NE(ExpectProblem(upload(BurstTar(3, Png(65, 64), 65, 64)), 422)
                .find("exceed limits.max_frame_pixels (4096 pixels)"),
            std::string::npos);
  // A decompression bomb: the manifest is small, the PNG header is not.
  std::string bomb = Png(8, 8);
  bomb[18] = 0x40;  // width 0x4008
  bomb[22] = 0x40;  // height 0x4008
  EXPECT_NE(ExpectProblem(upload(BurstTar(3, bomb, 8, 8)), 422)
                .find("the file declares 16392x16392, the manifest says 8x8"),
            std::string::npos);
  // A file the manifest does not name: it would be stored and served back.
  {
    std::map<std::string, std::string> files = {{"burst/manifest.json", ""},
                                                {"burst/notes/extra.bin", "not a frame"}};
    nlohmann::json manifest = {{"format", "dfsm-burst/1"}, {"width", 8}, {"height", 8}};
    for (int i = 0; i < 3; ++i) {
      const std::string name = "frames/" + std::to_string(i) + ".png";
      manifest["frames"].push_back({{"file", name}});
      files["burst/" + name] = Png(8, 8);
    }
    files["burst/manifest.json"] = manifest.dump();
    EXPECT_NE(ExpectProblem(upload(Tar(files)), 422).find("'notes/extra.bin' is not a file of"),
              std::string::npos);
  }
  EXPECT_TRUE(routes_->store().List().empty());
  EXPECT_EQ(upload(BurstTar(3, Png(8, 8), 8, 8))->status, 202);
}

// A problem names the file, never where the daemon keeps its state. An upload's
// 422 names the file inside the burst; the 507, file-gone and calibration
// details (which showed absolute paths) go through HideStateDirectory, which
// writes "<state_dir>" for it.
TEST_F(SecurityRoutesTest, ProblemsDoNotShowTheStateDirectory) {
  const std::map<std::string, std::string> files = {
      {"burst/manifest.json",
       nlohmann::json(
           {{"format", "dfsm-burst/1"},
            {"width", 8},
            {"height", 8},
            {"frames",
             {{{"file", "frames/0.png"}}, {{"file", "frames/1.png"}}, {{"file", "frames/2.png"}}}}})
           .dump()},
      {"burst/frames/0.png", Png(8, 8)},
      {"burst/frames/1.png", Png(8, 8)}};
  const std::string detail =
      ExpectProblem(client_->Post("/api/v1/jobs", Tar(files), "application/x-tar"), 422);
  EXPECT_NE(detail.find("frames/2.png"), std::string::npos) << detail;
  EXPECT_EQ(detail.find(routes_->dir().string()), std::string::npos) << detail;
  EXPECT_EQ(HideStateDirectory("/var/lib/dfsmd/jobs/x/job.json.tmp: No space left on device",
                               "/var/lib/dfsmd/"),
            "<state_dir>/jobs/x/job.json.tmp: No space left on device");
}

}  // namespace
}  // namespace dfsm::api
