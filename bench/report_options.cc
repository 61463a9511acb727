#include "bench/report_options.h"

#include <cctype>
#include <cmath>
#include <limits>
#include <optional>
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

// `read` (a std::sto* call, given the text and where to say how much of it it
// used) applied to `text` where Plain() allows it; nothing unless it read a
// value from all of the text.
template <typename T, typename Read>
std::optional<T> ReadAll(const std::string& text, bool plain, Read read) {
  if (!plain) return std::nullopt;
  size_t used = 0;
  T value{};
  try {
    value = read(text, &used);
  } catch (const std::logic_error&) {  // std::sto*'s invalid_argument and out_of_range
    return std::nullopt;
  }
  if (used != text.size()) return std::nullopt;
  return value;
}

// A finite number, all of `text`, at least `least` (more than it where
// `strictly`).
double Number(const char* option, const std::string& text, double least, bool strictly,
              const char* what) {
  const std::optional<double> value =
      ReadAll<double>(text, Plain(text, true, true),
                      [](const std::string& t, size_t* used) { return std::stod(t, used); });
  if (!value || !std::isfinite(*value) || (strictly ? *value <= least : *value < least))
    Refuse(option, what, text);
  return *value;
}

}  // namespace

int WholeNumber(const char* option, const std::string& text, int least) {
  const std::optional<long long> value =
      ReadAll<long long>(text, Plain(text, true, false),
                         [](const std::string& t, size_t* used) { return std::stoll(t, used); });
  if (!value || *value < least || *value > std::numeric_limits<int>::max())
    Refuse(option, "a whole number >= " + std::to_string(least), text);
  return static_cast<int>(*value);
}

double PositiveNumber(const char* option, const std::string& text) {
  return Number(option, text, 0.0, true, "a number > 0");
}

double NonNegativeNumber(const char* option, const std::string& text) {
  return Number(option, text, 0.0, false, "a number >= 0");
}

uint64_t SeedNumber(const char* option, const std::string& text) {
  // Digits only: std::stoull reads "-1" as 2^64 - 1.
  const std::optional<unsigned long long> value = ReadAll<unsigned long long>(
      text, Plain(text, false, false),
      [](const std::string& t, size_t* used) { return std::stoull(t, used); });
  if (!value) Refuse(option, "a whole number >= 0", text);
  return static_cast<uint64_t>(*value);
}

bool OnOff(const char* option, const std::string& text) {
  if (text != "on" && text != "off") Refuse(option, "on or off", text);
  return text == "on";
}

}  // namespace dfsm
