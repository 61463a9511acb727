#include "daemon/service/config.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "daemon/service/config_keys.h"

namespace dfsm::service {
namespace {

std::string ConfigErrorOf(const std::function<void()>& body) {
  try {
    body();
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(ConfigTest, DefaultsAreValidAndServeLoopback) {
  const DaemonConfig config;
  EXPECT_NO_THROW(Validate(config));
  EXPECT_EQ(config.server.listen, "127.0.0.1");
  EXPECT_EQ(config.server.port, 8080);
  EXPECT_EQ(config.jobs.workers, 1);
  EXPECT_EQ(config.jobs.queue, 8);
  EXPECT_TRUE(config.server.cors_origin.empty());
}

TEST(ConfigTest, TomlSetsEveryKindOfValue) {
  DaemonConfig config;
  const auto keys = ApplyToml(R"(
[server]
port = 9000
max_body_bytes = 1048576
[capture]
source = "v4l2:/dev/video2"
fps = 30
[pipeline]
init = "naive"
dense = false
[jobs]
state_dir = "/tmp/x"
)",
                              "test.toml", &config);
  EXPECT_EQ(keys.size(), 7u);
  EXPECT_EQ(config.server.port, 9000);
  EXPECT_EQ(config.server.max_body_bytes, 1048576);
  EXPECT_EQ(config.capture.source, "v4l2:/dev/video2");
  EXPECT_DOUBLE_EQ(config.capture.fps, 30.0);  // an integer is a fine number
  EXPECT_EQ(config.pipeline.init, InitMode::kNaive);
  EXPECT_FALSE(config.pipeline.dense);
  EXPECT_EQ(config.jobs.state_dir, "/tmp/x");
}

TEST(ConfigTest, ErrorsNameTheKeyAndTheProblem) {
  DaemonConfig config;
  EXPECT_EQ(ConfigErrorOf([&] { ApplyToml("[server]\nprot = 1\n", "f", &config); }),
            "server.prot: unknown key (see dfsmd --help)");
  EXPECT_EQ(ConfigErrorOf([&] { ApplyToml("[server]\nport = \"80\"\n", "f", &config); }),
            "server.port: expected an integer, got string");
  EXPECT_EQ(ConfigErrorOf([&] { ApplyToml("port = 80\n", "f", &config); }),
            "port: expected a [section], got a value");
  EXPECT_NE(ConfigErrorOf([&] { ApplyToml("[server\n", "f.toml", &config); }).find("f.toml:1"),
            std::string::npos);
  config.jobs.queue = 0;
  EXPECT_EQ(ConfigErrorOf([&] { Validate(config); }), "jobs.queue: must be in [1, 100000], got 0");
  config = DaemonConfig();
  config.capture.source = "usb:0";
  EXPECT_NE(ConfigErrorOf([&] { Validate(config); }).find("capture.source: 'usb:0' is not"),
            std::string::npos);
  config = DaemonConfig();
  config.pipeline.frames = 100;  // more than the ring holds
  EXPECT_NE(ConfigErrorOf([&] { Validate(config); }).find("pipeline.frames"), std::string::npos);
  config = DaemonConfig();
  config.pipeline.still_parallax_px = 2 * config.pipeline.auto_parallax_px;
  EXPECT_NE(ConfigErrorOf([&] { Validate(config); }).find("pipeline.still_parallax_px"),
            std::string::npos);
  EXPECT_EQ(ConfigErrorOf([&] { ApplyToml("[pipeline]\nwhen = \"now\"\n", "f", &config); }),
            "pipeline.when: must be \"last\" or \"next\", got \"now\"");
  config = DaemonConfig();
  config.pipeline.rolling_shutter = "fast";
  EXPECT_NE(ConfigErrorOf([&] {
              Validate(config);
            }).find("pipeline.rolling_shutter: rolling shutter must be"),
            std::string::npos);
}

TEST(ConfigTest, FlagsWinOverTheFileWhereverTheyStand) {
  const std::filesystem::path file =
      std::filesystem::temp_directory_path() / ("dfsmd-config-test-" + std::to_string(::getpid()));
  std::ofstream(file) << "[server]\nport = 9000\nthreads = 4\n";
  const CommandLine line =
      ParseCommandLine({"--server.port", "9100", "--config", file.string(), "--jobs.queue=3"});
  std::filesystem::remove(file);
  EXPECT_EQ(line.config.server.port, 9100);
  EXPECT_EQ(line.config.server.threads, 4);
  EXPECT_EQ(line.config.jobs.queue, 3);
}

TEST(ConfigTest, BadFlagsAreNamed) {
  EXPECT_EQ(ConfigErrorOf([] {
              ParseCommandLine({"--server.port", "eighty"});
            }),
            "server.port: expected an integer, got 'eighty'");
  EXPECT_EQ(ConfigErrorOf([] {
              ParseCommandLine({"--sever.port", "80"});
            }),
            "--sever.port: unknown option (see dfsmd --help)");
  EXPECT_NE(ConfigErrorOf([] { ParseCommandLine({"--server.port"}); }).find("--server.port"),
            std::string::npos);
  EXPECT_EQ(ConfigErrorOf([] {
              ParseCommandLine({"--config", "/nonexistent/dfsmd.toml"});
            }),
            "--config: cannot read '/nonexistent/dfsmd.toml'");
  EXPECT_EQ(ConfigErrorOf([] {
              ParseCommandLine({"--pipeline.dense", "maybe"});
            }),
            "pipeline.dense: expected true or false, got 'maybe'");
  EXPECT_NE(ConfigErrorOf([] { ParseCommandLine({"stray"}); }).find("unexpected argument"),
            std::string::npos);
}

// The table is the one place a range or a list is written: Validate, the
// flags and the capture layer's own check read the same bounds.
TEST(ConfigTest, TheTableHoldsTheRangesAndChoices) {
  for (const ConfigKey& key : ConfigKeys()) {
    EXPECT_NE(key.name.find('.'), std::string::npos) << key.name;
    EXPECT_FALSE(key.help.empty()) << key.name;
    if (key.type == KeyType::kInt || key.type == KeyType::kInt64) {
      EXPECT_LE(key.min, key.max) << key.name;
      DaemonConfig config;
      config.capture.ring_frames = ConfigKeyNamed("capture.ring_frames").max;
      key.SetFromText(std::to_string(key.max), &config);
      EXPECT_EQ(ConfigErrorOf([&] { Validate(config); }).find(key.name + ":"), std::string::npos)
          << key.name << " refuses its own maximum";
      if (key.max < std::numeric_limits<int64_t>::max()) {
        key.SetFromText(std::to_string(key.max + 1), &config);
        EXPECT_EQ(ConfigErrorOf([&] { Validate(config); }).rfind(key.name + ":", 0), 0u)
            << key.name;
      }
    }
    if (key.type == KeyType::kChoice) {
      for (const std::string& choice : key.choices) {
        DaemonConfig config;
        key.SetFromText(choice, &config);
        EXPECT_EQ(key.ValueText(config), "\"" + choice + "\"");
      }
    }
  }
  // --check-config and start-up once disagreed on device_buffers (64 and 32).
  EXPECT_EQ(ConfigErrorOf([] {
              ParseCommandLine({"--capture.device_buffers", "33"});
            }),
            "capture.device_buffers: must be in [4, 32], got 33");
  EXPECT_EQ(
      ParseCommandLine({"--pipeline.init", "naive", "--pipeline.when=next"}).config.pipeline.init,
      InitMode::kNaive);
}

TEST(ConfigTest, SystemdStateDirectoryIsTheDefaultOnly) {
  ::setenv("STATE_DIRECTORY", "/var/lib/dfsmd-test:/other", 1);
  EXPECT_EQ(ParseCommandLine({}).config.jobs.state_dir, "/var/lib/dfsmd-test");
  EXPECT_EQ(ParseCommandLine({"--jobs.state_dir", "/srv/x"}).config.jobs.state_dir, "/srv/x");
  ::unsetenv("STATE_DIRECTORY");
}

TEST(ConfigTest, ShippedConfigFileIsValidAndDocumentsEveryKey) {
  const std::string path = std::string(DFSM_SOURCE_DIR) + "/config/dfsmd.toml";
  const CommandLine line = ParseCommandLine({"--config", path});
  // "the values shown are the defaults": the file and the table agree.
  for (const ConfigKey& key : ConfigKeys()) {
    if (key.name == "jobs.state_dir") continue;  // $STATE_DIRECTORY may stand in
    EXPECT_EQ(key.ValueText(line.config), key.ValueText(DaemonConfig())) << key.name;
  }
  std::ifstream in(path);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::istringstream keys(DescribeKeys());
  std::string line_text;
  int described = 0;
  while (std::getline(keys, line_text)) {
    if (line_text.rfind("  --", 0) != 0) continue;
    const std::string key = line_text.substr(4, line_text.find(' ', 4) - 4);
    const std::string name = key.substr(key.find('.') + 1);
    EXPECT_NE(text.find(name + " = "), std::string::npos) << key << " missing in dfsmd.toml";
    ++described;
  }
  EXPECT_GT(described, 25);
}

}  // namespace
}  // namespace dfsm::service
