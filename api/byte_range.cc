#include "api/byte_range.h"

#include <algorithm>
#include <charconv>

#include "api/request_head.h"

namespace dfsm::api {
namespace {

// Optional white space (RFC 9110 section 5.6.3) off both ends.
std::string_view TrimOws(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

// Up to 18 decimal digits (no overflow), nothing else; nullopt otherwise.
std::optional<uint64_t> Number(std::string_view digits) {
  if (digits.empty() || digits.size() > 18 ||
      !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return std::nullopt;
  uint64_t value = 0;
  std::from_chars(digits.data(), digits.data() + digits.size(), value);
  return value;
}

}  // namespace

std::optional<ByteRange> ParseSingleByteRange(std::string_view value) {
  value = TrimOws(value);
  const size_t equals = value.find('=');
  if (equals == std::string_view::npos ||
      !EqualsIgnoringCase(TrimOws(value.substr(0, equals)), "bytes"))
    return std::nullopt;
  const std::string_view spec = TrimOws(value.substr(equals + 1));
  if (spec.find(',') != std::string_view::npos) return std::nullopt;
  const size_t dash = spec.find('-');
  if (dash == std::string_view::npos) return std::nullopt;
  const std::string_view first = spec.substr(0, dash);
  const std::string_view last = spec.substr(dash + 1);
  ByteRange range;
  if (first.empty()) {
    range.suffix = Number(last);
    return range.suffix ? std::optional<ByteRange>(range) : std::nullopt;
  }
  range.first = Number(first);
  if (!range.first) return std::nullopt;
  if (!last.empty()) {
    range.last = Number(last);
    if (!range.last || *range.last < *range.first) return std::nullopt;
  }
  return range;
}

std::string FormatRangeSpec(const ByteRange& range) {
  if (range.suffix) return "-" + std::to_string(*range.suffix);
  return std::to_string(range.first.value_or(0)) + "-" +
         (range.last ? std::to_string(*range.last) : std::string());
}

std::optional<ByteSlice> ResolveRange(const ByteRange& range, uint64_t size) {
  if (range.suffix) {
    if (*range.suffix == 0 || size == 0) return std::nullopt;
    const uint64_t length = std::min(*range.suffix, size);
    return ByteSlice{size - length, length};
  }
  const uint64_t first = range.first.value_or(0);
  if (first >= size) return std::nullopt;
  const uint64_t last = std::min(range.last.value_or(size - 1), size - 1);
  return ByteSlice{first, last - first + 1};
}

}  // namespace dfsm::api
