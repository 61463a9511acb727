#include "daemon/service/config.h"

#include <toml++/toml.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include "core/camera/rolling_shutter_options.h"
#include "daemon/service/access_token.h"
#include "daemon/service/config_keys.h"

namespace dfsm::service {
namespace {

std::string WithArticle(KeyType type) {
  return (type == KeyType::kInt || type == KeyType::kInt64 ? "an " : "a ") +
         std::string(TypeName(type));
}

// A TOML value of the key's type goes through the key's text reader, so the
// file and the command line convert and range-check alike.
void SetFromToml(const ConfigKey& key, const toml::node& node, DaemonConfig* config) {
  bool right_type = false;
  switch (key.type) {
    case KeyType::kString:
    case KeyType::kPath:
    case KeyType::kChoice:
      right_type = node.is_string();
      if (right_type) key.SetFromText(*node.value<std::string>(), config);
      break;
    case KeyType::kInt:
    case KeyType::kInt64:
      right_type = node.is_integer();
      if (right_type) key.SetFromText(std::to_string(*node.value<int64_t>()), config);
      break;
    case KeyType::kDouble:
      right_type = node.is_number();  // an integer is a fine number
      if (right_type) *static_cast<double*>(key.field(config)) = *node.value<double>();
      break;
    case KeyType::kBool:
      right_type = node.is_boolean();
      if (right_type) key.SetFromText(*node.value<bool>() ? "true" : "false", config);
      break;
  }
  if (!right_type) {
    std::ostringstream got;
    got << node.type();
    throw KeyError(key.name, "expected " + WithArticle(key.type) + ", got " + got.str());
  }
}

}  // namespace

void Validate(const DaemonConfig& c) {
  for (const ConfigKey& key : ConfigKeys()) {
    if (const auto problem = key.Problem(c)) throw KeyError(key.name, *problem);
  }
  // What a range or a list cannot say.
  if (c.server.listen.empty()) throw KeyError("server.listen", "must not be empty");
  if (c.server.allowed_hosts.find_first_of("\r\n") != std::string::npos) {
    throw KeyError("server.allowed_hosts", "must not contain line breaks");
  }
  if (c.server.cors_origin.find_first_of("\r\n") != std::string::npos) {
    throw KeyError("server.cors_origin", "must not contain line breaks");
  }
  const std::string& credential = c.server.token_credential;
  if (credential.find('/') != std::string::npos || credential == "." || credential == "..") {
    throw KeyError("server.token_credential", "must be a credential name, not a path");
  }
  const std::string& source = c.capture.source;
  const size_t colon = source.find(':');
  const std::string scheme = colon == std::string::npos ? "" : source.substr(0, colon);
  if (scheme != "v4l2" && scheme != "libcamera" && scheme != "replay" && scheme != "synthetic") {
    throw KeyError("capture.source", "'" + source +
                                         "' is not v4l2:<device>, libcamera:<id>, "
                                         "replay:<burst dir> or synthetic:");
  }
  if (c.pipeline.frames > c.capture.ring_frames) {
    throw KeyError("pipeline.frames", "must be at most capture.ring_frames (" +
                                          std::to_string(c.capture.ring_frames) + "), got " +
                                          std::to_string(c.pipeline.frames));
  }
  if (c.pipeline.auto_parallax_px <= 0) {
    throw KeyError("pipeline.auto_parallax_px", "must be more than 0");
  }
  if (c.pipeline.still_parallax_px > c.pipeline.auto_parallax_px) {
    throw KeyError("pipeline.still_parallax_px", "must be at most pipeline.auto_parallax_px");
  }
  try {
    ParseRollingShutter(c.pipeline.rolling_shutter);
  } catch (const std::invalid_argument& e) {
    throw KeyError("pipeline.rolling_shutter", e.what());
  }
  if (c.jobs.state_dir.empty()) throw KeyError("jobs.state_dir", "must not be empty");
}

std::vector<std::string> ApplyToml(const std::string& text, const std::string& origin,
                                   DaemonConfig* config) {
  std::vector<std::string> applied;
  toml::table root;
  try {
    root = toml::parse(text, origin);
  } catch (const toml::parse_error& e) {
    std::ostringstream message;
    message << origin << ":" << e.source().begin.line << ":" << e.source().begin.column
            << ": not valid TOML: " << e.description();
    throw ConfigError(message.str());
  }
  for (const auto& [section_name, section] : root) {
    const std::string section_key(section_name.str());
    const toml::table* table = section.as_table();
    if (!table) throw KeyError(section_key, "expected a [section], got a value");
    for (const auto& [key_name, value] : *table) {
      const std::string name = section_key + "." + std::string(key_name.str());
      const ConfigKey* key = FindConfigKey(name);
      if (!key) throw KeyError(name, "unknown key (see dfsmd --help)");
      SetFromToml(*key, value, config);
      applied.push_back(name);
    }
  }
  return applied;
}

void ApplyFlag(const std::string& name, const std::string& value, DaemonConfig* config) {
  const ConfigKey* key = FindConfigKey(name);
  if (!key) throw KeyError("--" + name, "unknown option (see dfsmd --help)");
  key->SetFromText(value, config);
}

CommandLine ParseCommandLine(const std::vector<std::string>& args) {
  CommandLine line;
  // CLI11 collects the text of every flag; the table converts it after the
  // file is read, so flags win wherever they stand.
  CLI::App app("dfsmd", "dfsmd");
  app.set_help_flag();  // --help lists the table (DescribeKeys), not CLI11's layout
  app.allow_extras();   // reported below in the table's words
  std::string file;
  app.add_flag("-h,--help", line.help);
  app.add_flag("--check-config", line.check_only);
  app.add_option("--config", file);
  std::map<std::string, std::string> flags;
  for (const ConfigKey& key : ConfigKeys()) {
    app.add_option_function<std::string>(
           "--" + key.name, [&flags, &key](const std::string& value) { flags[key.name] = value; },
           key.help)
        ->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
  }
  try {
    app.parse(std::vector<std::string>(args.rbegin(), args.rend()));
  } catch (const CLI::ParseError& e) {
    throw ConfigError(e.what());
  }
  if (!app.remaining().empty()) {
    const std::string arg = app.remaining().front();
    if (arg.rfind("--", 0) != 0 || arg.size() == 2) {
      throw ConfigError("'" + arg + "': unexpected argument (options are --section.key VALUE)");
    }
    throw KeyError(arg.substr(0, arg.find('=')), "unknown option (see dfsmd --help)");
  }
  bool state_dir_set = flags.count("jobs.state_dir") > 0;
  if (!file.empty()) {
    std::ifstream in(file);
    if (!in) throw ConfigError("--config: cannot read '" + file + "'");
    std::ostringstream text;
    text << in.rdbuf();
    const std::vector<std::string> set = ApplyToml(text.str(), file, &line.config);
    state_dir_set = state_dir_set || std::count(set.begin(), set.end(), "jobs.state_dir") > 0;
  }
  for (const auto& [name, value] : flags) ApplyFlag(name, value, &line.config);
  if (!state_dir_set) {
    // systemd's StateDirectory= names the directory it created for us.
    if (const char* dir = std::getenv("STATE_DIRECTORY"); dir && *dir) {
      std::string first(dir);
      first = first.substr(0, first.find(':'));
      line.config.jobs.state_dir = first;
    }
  }
  Validate(line.config);
  if (!line.help) ResolveAccessToken(&line.config.server, std::getenv("CREDENTIALS_DIRECTORY"));
  return line;
}

std::string DescribeKeys() {
  std::ostringstream out;
  const DaemonConfig defaults;
  for (const ConfigKey& key : ConfigKeys()) {
    out << "  --" << key.name << " " << TypeName(key.type) << " (default "
        << key.ValueText(defaults);
    if (key.type == KeyType::kInt || key.type == KeyType::kInt64 || key.type == KeyType::kDouble) {
      out << ", " << key.min << "..";
      if (key.max < std::numeric_limits<int64_t>::max()) out << key.max;  // else unbounded
    }
    out << ")\n      " << key.help;
    for (size_t i = 0; i < key.choices.size(); ++i) {
      out << (i == 0 ? ": " : " | ") << key.choices[i];
    }
    out << "\n";
  }
  return out.str();
}

}  // namespace dfsm::service
