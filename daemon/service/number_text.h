// Whole-string number parsing for text a user typed (flags, query strings):
// "12" is 12, but "12abc", " 12", "" and out-of-range values are no number.
#pragma once

#include <cstdint>
#include <exception>
#include <optional>
#include <string>

namespace dfsm::service {

inline std::optional<int64_t> ParseInteger(const std::string& text) {
  size_t used = 0;
  int64_t value = 0;
  try {
    value = std::stoll(text, &used, 10);
  } catch (const std::exception&) {
    return std::nullopt;
  }
  if (text.empty() || used != text.size()) return std::nullopt;
  return value;
}

inline std::optional<double> ParseReal(const std::string& text) {
  size_t used = 0;
  double value = 0.0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    return std::nullopt;
  }
  if (text.empty() || used != text.size()) return std::nullopt;
  return value;
}

}  // namespace dfsm::service
