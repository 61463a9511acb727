// Fuzzes dfsmd's configuration reader and its options table
// (daemon/service/config.h, config_keys.h): a TOML file
// through ApplyToml, or, when the input starts with "--", one
// "--section.key=value" flag per line through ApplyFlag; then Validate.
// Anything unusable must be a ConfigError naming the key or the line. (The
// flags are applied one by one rather than through ParseCommandLine, which
// would also open files named by --config and read credentials.)
#include <cstddef>
#include <cstdint>
#include <optional>
#include <sstream>
#include <string>

#include "daemon/service/config.h"
#include "daemon/service/config_keys.h"
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
  // A configuration that passed Validate is what the daemon runs with: every
  // key within the options table's range or choices, and written back as a
  // flag, every value reads as itself.
  DaemonConfig copy;
  for (const dfsm::service::ConfigKey& key : dfsm::service::ConfigKeys()) {
    const std::optional<std::string> problem = key.Problem(config);
    FUZZ_CHECK(!problem, key.name + ": " + problem.value_or(""));
    std::string text = key.ValueText(config);
    const bool quoted = text.size() >= 2 && text.front() == '"';
    if (quoted) text = text.substr(1, text.size() - 2);
    if (key.type == dfsm::service::KeyType::kDouble) continue;  // printed rounded
    key.SetFromText(text, &copy);
    FUZZ_CHECK(key.ValueText(copy) == key.ValueText(config), key.name + " does not read back");
  }
  FUZZ_CHECK(config.pipeline.frames <= config.capture.ring_frames,
             "pipeline.frames over capture.ring_frames");
  return 0;
}
