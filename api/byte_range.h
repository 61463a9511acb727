// Range requests (RFC 9110 section 14), decided in dfsmd's front gate.
//
// cpp-httplib 0.11 answers a Range of N ranges with a multipart body it builds
// in memory: N copies of the file, so one 8 KiB header of "0-,0-,..." asked a
// 1.2 MB job file for 3.3 GB. The gate therefore never lets a Range field
// reach httplib. One byte range it passes on under kGateRangeField, which the
// file routes serve as a 206 from a bounded stream (ServeRange in routes.cc);
// anything else (several ranges, another unit, bad syntax) it drops, and the
// file is served whole with 200, as RFC 9110 section 14.2 allows a server to
// ignore Range.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace dfsm::api {

// The field the gate writes for the route; a client's own copy is dropped.
inline constexpr const char* kGateRangeField = "Dfsm-Range";

// One range-spec: "first-last", "first-" (to the end) or "-suffix" (the last
// `suffix` bytes).
struct ByteRange {
  std::optional<uint64_t> first;
  std::optional<uint64_t> last;    // inclusive; absent: to the end
  std::optional<uint64_t> suffix;  // set only for "-suffix"
};

// The single byte range of a Range field value ("bytes=0-99"), or nullopt for
// anything else: several ranges, another unit, last < first, numbers of more
// than 18 digits, stray characters.
std::optional<ByteRange> ParseSingleByteRange(std::string_view value);

// "0-99", "100-", "-500": the range-spec as kGateRangeField carries it.
std::string FormatRangeSpec(const ByteRange& range);

// The bytes a range selects of a representation of `size` bytes, or nullopt
// when it selects none (416: first at or past the end, or a suffix of 0).
struct ByteSlice {
  uint64_t offset = 0;
  uint64_t length = 0;
};
std::optional<ByteSlice> ResolveRange(const ByteRange& range, uint64_t size);

}  // namespace dfsm::api
