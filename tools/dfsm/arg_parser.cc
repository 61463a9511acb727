#include "tools/dfsm/arg_parser.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>

namespace dfsm::tools {

ArgParser::ArgParser(std::set<std::string> flags_with_value, std::set<std::string> switches)
    : flags_with_value_(std::move(flags_with_value)), switches_(std::move(switches)) {}

void ArgParser::Parse(const std::vector<std::string>& args) {
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    if (arg.rfind("--", 0) != 0 || arg == "--") {
      positionals_.push_back(arg);
      continue;
    }
    std::string name = arg.substr(2);
    std::string value;
    bool has_value = false;
    if (const auto eq = name.find('='); eq != std::string::npos) {
      value = name.substr(eq + 1);
      name = name.substr(0, eq);
      has_value = true;
    }
    if (switches_.count(name)) {
      if (has_value) throw UsageError("--" + name + " takes no value");
      values_[name] = "1";
    } else if (flags_with_value_.count(name)) {
      if (!has_value) {
        if (i + 1 >= args.size()) throw UsageError("--" + name + " needs a value");
        value = args[++i];
      }
      values_[name] = value;
    } else {
      throw UsageError("unknown option --" + name);
    }
  }
}

std::string ArgParser::String(const std::string& flag, const std::string& fallback) const {
  const auto it = values_.find(flag);
  return it == values_.end() ? fallback : it->second;
}

int ArgParser::Int(const std::string& flag, int fallback) const {
  const auto it = values_.find(flag);
  if (it == values_.end()) return fallback;
  char* end = nullptr;
  errno = 0;
  const long value = std::strtol(it->second.c_str(), &end, 10);
  if (errno != 0 || end == it->second.c_str() || *end != '\0' || value < -1000000000L ||
      value > 1000000000L)
    throw UsageError("--" + flag + ": '" + it->second + "' is not an integer");
  return static_cast<int>(value);
}

double ArgParser::Double(const std::string& flag, double fallback) const {
  const auto it = values_.find(flag);
  if (it == values_.end()) return fallback;
  char* end = nullptr;
  errno = 0;
  const double value = std::strtod(it->second.c_str(), &end);
  if (errno != 0 || end == it->second.c_str() || *end != '\0' || !std::isfinite(value))
    throw UsageError("--" + flag + ": '" + it->second + "' is not a number");
  return value;
}

}  // namespace dfsm::tools
