// Whole-string number parsing for text a user typed (flags, query strings):
// "12" is 12, but "12abc", " 12", "+12", "", "0x1A" and out-of-range values are
// no number; nor, for reals, are "inf" and "nan".
//
// Built on std::from_chars rather than std::stoll/std::stod: those skip leading
// white space, take a '+' sign, and stod reads "inf", "nan" and hexadecimal
// floats, so " 12", "+12", "nan" and "0x1p3" passed as numbers. from_chars takes
// only an optional '-', digits and (for reals) a fraction and exponent, ignores
// the locale and never throws.
#pragma once

#include <charconv>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string_view>
#include <system_error>

namespace dfsm::service {

inline std::optional<int64_t> ParseInteger(std::string_view text) {
  int64_t value = 0;
  const char* const end = text.data() + text.size();
  const auto [stop, error] = std::from_chars(text.data(), end, value, 10);
  if (error != std::errc() || stop != end) return std::nullopt;
  return value;
}

inline std::optional<double> ParseReal(std::string_view text) {
  double value = 0.0;
  const char* const end = text.data() + text.size();
  const auto [stop, error] = std::from_chars(text.data(), end, value, std::chars_format::general);
  // from_chars reads "inf", "infinity" and "nan" (any case) as a number.
  if (error != std::errc() || stop != end || !std::isfinite(value)) return std::nullopt;
  return value;
}

}  // namespace dfsm::service
