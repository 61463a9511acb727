// Fuzzes dfsmd's configuration reader (daemon/service/config.h): a TOML file
// through ApplyToml, or, when the input starts with "--", one
// "--section.key=value" flag per line through ApplyFlag; then Validate.
// Anything unusable must be a ConfigError naming the key or the line. (The
// flags are applied one by one rather than through ParseCommandLine, which
// would also open files named by --config and read credentials.)
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "daemon/service/config.h"
#include "fuzz/fuzz_check.h"

namespace {

using dfsm::service::ConfigError;
using dfsm::service::DaemonConfig;

void ApplyFlags(const std::string& text, DaemonConfig* config) {
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    const size_t equals = line.find('=');
    if (line.rfind("--", 0) != 0 || equals == std::string::npos) continue;
    dfsm::service::ApplyFlag(line.substr(2, equals - 2), line.substr(equals + 1), config);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text = dfsm::fuzz::AsText(data, size);
  DaemonConfig config;
  try {
    if (text.rfind("--", 0) == 0) {
      ApplyFlags(text, &config);
    } else {
      for (const std::string& key : dfsm::service::ApplyToml(text, "fuzz.toml", &config)) {
        FUZZ_CHECK(key.find('.') != std::string::npos, "applied a key without a section: " + key);
      }
    }
    dfsm::service::Validate(config);
  } catch (const ConfigError& error) {
    dfsm::fuzz::CheckNamedError(error);
    return 0;
  }
  // A configuration that passed Validate is what the daemon runs with.
  FUZZ_CHECK(config.server.port >= 0 && config.server.port <= 65535, "port out of range");
  FUZZ_CHECK(config.pipeline.frames >= 3 && config.pipeline.frames <= config.capture.ring_frames,
             "pipeline.frames outside [3, ring_frames]");
  FUZZ_CHECK(config.server.max_body_bytes >= 1024, "max_body_bytes below 1 KiB");
  return 0;
}
