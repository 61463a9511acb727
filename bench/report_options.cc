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

// Digits, with at most a leading minus where `signed_ok`; for a number also a
// decimal point and a decimal exponent. std::sto* would also take leading
// white space, a plus sign, hexadecimal, "inf" and "nan".
bool Plain(const std::string& text, bool signed_ok, bool real) {
  if (text.empty()) return false;
  size_t i = signed_ok && text[0] == '-' ? 1 : 0;
  if (i == text.size() || !std::isdigit(static_cast<unsigned char>(text[i]))) return false;
  for (; i < text.size(); ++i) {
    const char c = text[i];
    const bool ok =
        std::isdigit(static_cast<unsigned char>(c)) ||
        (real && (c == '.' || c == 'e' || c == 'E' ||
                  ((c == '-' || c == '+') && (text[i - 1] == 'e' || text[i - 1] == 'E'))));
    if (!ok) return false;
  }
  return true;
}

// A finite number, all of `text`, at least `least` (more than it where
// `strictly`).
double Number(const char* option, const std::string& text, double least, bool strictly,
              const char* what) {
  size_t used = 0;
  double value = 0.0;
  try {
    if (Plain(text, true, true)) value = std::stod(text, &used);
  } catch (const std::logic_error&) {  // std::stod's invalid_argument and out_of_range
    used = 0;
  }
  if (used == 0 || used != text.size() || !std::isfinite(value) ||
      (strictly ? value <= least : value < least))
    Refuse(option, what, text);
  return value;
}

}  // namespace

int WholeNumber(const char* option, const std::string& text, int least) {
  const std::string what = "a whole number >= " + std::to_string(least);
  size_t used = 0;
  long long value = 0;
  try {
    if (Plain(text, true, false)) value = std::stoll(text, &used);
  } catch (const std::logic_error&) {  // std::stoll's invalid_argument and out_of_range
    used = 0;
  }
  if (used == 0 || used != text.size() || value < least || value > std::numeric_limits<int>::max())
    Refuse(option, what, text);
  return static_cast<int>(value);
}

double PositiveNumber(const char* option, const std::string& text) {
  return Number(option, text, 0.0, true, "a number > 0");
}

double NonNegativeNumber(const char* option, const std::string& text) {
  return Number(option, text, 0.0, false, "a number >= 0");
}

uint64_t SeedNumber(const char* option, const std::string& text) {
  size_t used = 0;
  unsigned long long value = 0;
  try {
    // Digits only: std::stoull reads "-1" as 2^64 - 1.
    if (Plain(text, false, false)) value = std::stoull(text, &used);
  } catch (const std::logic_error&) {
    used = 0;
  }
  if (used == 0 || used != text.size()) Refuse(option, "a whole number >= 0", text);
  return static_cast<uint64_t>(value);
}

}  // namespace dfsm
