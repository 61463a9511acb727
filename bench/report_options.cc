#include "bench/report_options.h"

#include <cctype>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace dfsm {
namespace {

[[noreturn]] void Refuse(const char* option, const std::string& what, const std::string& text) {
  throw std::invalid_argument(std::string(option) + " takes " + what + ", got '" + text + "'");
}

// std::sto* skip leading white space and stop at the first character they
// cannot read; neither is an option's value.
bool StartsWithSpace(const std::string& text) {
  return !text.empty() && std::isspace(static_cast<unsigned char>(text[0]));
}

}  // namespace

int WholeNumber(const char* option, const std::string& text, int least) {
  const std::string what = "a whole number >= " + std::to_string(least);
  size_t used = 0;
  long value = 0;
  try {
    if (!StartsWithSpace(text)) value = std::stol(text, &used);
  } catch (const std::logic_error&) {  // std::stol's invalid_argument and out_of_range
    used = 0;
  }
  if (used == 0 || used != text.size() || value < least || value > std::numeric_limits<int>::max())
    Refuse(option, what, text);
  return static_cast<int>(value);
}

double RealNumber(const char* option, const std::string& text) {
  size_t used = 0;
  double value = 0.0;
  try {
    if (!StartsWithSpace(text)) value = std::stod(text, &used);
  } catch (const std::logic_error&) {
    used = 0;
  }
  if (used == 0 || used != text.size() || !std::isfinite(value)) Refuse(option, "a number", text);
  return value;
}

uint64_t SeedNumber(const char* option, const std::string& text) {
  size_t used = 0;
  unsigned long long value = 0;
  // std::stoull reads "-1" as 2^64 - 1: a seed has digits only.
  const bool digits = !text.empty() && std::isdigit(static_cast<unsigned char>(text[0]));
  try {
    if (digits) value = std::stoull(text, &used);
  } catch (const std::logic_error&) {
    used = 0;
  }
  if (used == 0 || used != text.size()) Refuse(option, "a whole number >= 0", text);
  return static_cast<uint64_t>(value);
}

}  // namespace dfsm
