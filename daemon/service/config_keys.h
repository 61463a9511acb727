// dfsmd's options table: every configuration key once, with its member of
// DaemonConfig, its type, its range or choices and its help. The TOML reader,
// the command line, --help, Validate(), the per-job overrides (api/
// job_request.h) and the test of api/openapi.json all read this table, so a
// range or a list of choices is written here and nowhere else.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "daemon/service/config.h"

namespace dfsm::service {

enum class KeyType { kString, kPath, kInt, kInt64, kDouble, kBool, kChoice };

struct ConfigKey {
  std::string name;  // "section.key"
  KeyType type = KeyType::kString;
  // Integers and numbers: the closed range [min, max]. A key whose upper
  // bound is another key (pipeline.frames <= capture.ring_frames) has the
  // widest bound here and the tighter one checked by Validate().
  int64_t min = 0, max = 0;
  // kChoice: the names of the enum's values, in the enum's order; a kString
  // key with choices must hold one of them.
  std::vector<std::string> choices;
  std::string help;
  // The member the key sets: void* to a string, path, int, int64_t, double or
  // bool by `type`; for kChoice, the enum's value as an index into choices.
  std::function<void*(DaemonConfig*)> field;
  std::function<size_t(const DaemonConfig&)> get_choice;
  std::function<void(DaemonConfig*, size_t)> set_choice;

  // What is wrong with a value of this key ("must be in [2, 1024], got 1"),
  // or nothing; the caller prefixes the key or field name.
  std::optional<std::string> RangeProblem(int64_t value) const;
  std::optional<std::string> RangeProblem(double value) const;
  std::optional<std::string> ChoiceProblem(const std::string& value) const;
  // What is wrong with the value `config` holds for this key by its range or
  // choices alone (Validate() adds the rules that tie keys together).
  std::optional<std::string> Problem(const DaemonConfig& config) const;
  // The index of `value` in choices; throws ConfigError naming the key.
  size_t ChoiceIndex(const std::string& value) const;

  // The value `config` holds, as text ("8080", "\"last\"" for strings).
  std::string ValueText(const DaemonConfig& config) const;
  // Sets the member from a flag's text; throws ConfigError naming the key.
  void SetFromText(const std::string& text, DaemonConfig* config) const;
};

// Every key, in the order of --help and config/dfsmd.toml.
const std::vector<ConfigKey>& ConfigKeys();

// nullptr where there is no such key.
const ConfigKey* FindConfigKey(std::string_view name);
// A key the code names; a missing one is a programming error (std::logic_error).
const ConfigKey& ConfigKeyNamed(std::string_view name);

// "integer", "number", "string", "boolean": TOML's and JSON Schema's names.
const char* TypeName(KeyType type);

ConfigError KeyError(const std::string& key, const std::string& problem);

}  // namespace dfsm::service
