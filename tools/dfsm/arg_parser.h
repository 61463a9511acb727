// A deliberately small flag parser: --name value, --name=value and positionals.
// Unknown flags and malformed numbers are usage errors that name the flag.
#pragma once

#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace dfsm::tools {

class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class ArgParser {
 public:
  // `flags_with_value` take an argument; `switches` do not.
  ArgParser(std::set<std::string> flags_with_value, std::set<std::string> switches = {});

  void Parse(const std::vector<std::string>& args);

  bool Has(const std::string& flag) const { return values_.count(flag) > 0; }
  std::string String(const std::string& flag, const std::string& fallback) const;
  int Int(const std::string& flag, int fallback) const;
  double Double(const std::string& flag, double fallback) const;
  const std::vector<std::string>& positionals() const { return positionals_; }

 private:
  std::set<std::string> flags_with_value_;
  std::set<std::string> switches_;
  std::map<std::string, std::string> values_;
  std::vector<std::string> positionals_;
};

}  // namespace dfsm::tools
