// JSON from outside the process (uploads, request bodies, files a user gives)
// parsed with a bound on nesting, and values quoted in error messages without
// serializing them whole.
#pragma once

#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>

namespace dfsm {

// Deeper nesting than any document dfsm reads (a manifest, a calibration, a
// request body) needs; 64 keeps every recursive walk of nlohmann::json
// (dump(), comparison, copy) far from the stack limit of a worker thread.
inline constexpr int kMaxJsonDepth = 64;

// Thrown for text that is not JSON or is nested deeper than allowed; what()
// names the problem (position, depth) without the offending text.
class JsonInputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Parses `text`, first refusing nesting deeper than `max_depth` arrays/objects
// by a linear scan, so that neither the parser nor anything later recurses
// through a hostile document (a 200 KB manifest of 100 000 nested arrays used
// to overflow the stack in dump()). Numbers out of a double's range and
// malformed text are JsonInputError too.
nlohmann::json ParseBoundedJson(const std::string& text, int max_depth = kMaxJsonDepth);

// A short description of a value for an error message: scalars as JSON,
// shortened to `max_chars`, containers as "an array of N elements" / "an
// object of N members". Never recurses into a container.
std::string DescribeJsonValue(const nlohmann::json& value, size_t max_chars = 64);

}  // namespace dfsm
