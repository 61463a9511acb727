#include "core/io/bounded_json.h"

namespace dfsm {

namespace {

// The deepest nesting of arrays/objects in `text`, outside string literals,
// stopping early once `limit` is exceeded. Returns the offset where the limit
// was crossed through `where`.
int NestingDepth(const std::string& text, int limit, size_t* where) {
  int depth = 0;
  int deepest = 0;
  bool in_string = false;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\')
        ++i;  // the escaped character cannot end the string
      else if (c == '"')
        in_string = false;
      continue;
    }
    if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > deepest) deepest = depth;
      if (depth > limit) {
        *where = i;
        return depth;
      }
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  return deepest;
}

}  // namespace

nlohmann::json ParseBoundedJson(const std::string& text, int max_depth) {
  size_t where = 0;
  if (NestingDepth(text, max_depth, &where) > max_depth)
    throw JsonInputError("nested deeper than " + std::to_string(max_depth) +
                         " arrays/objects (at byte " + std::to_string(where) + ")");
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    // Not only parse_error: a number too large for a double ("1e999") is an
    // out_of_range.
    throw JsonInputError(std::string("not valid JSON (") + e.what() + ")");
  }
}

std::string DescribeJsonValue(const nlohmann::json& value, size_t max_chars) {
  if (value.is_array()) return "an array of " + std::to_string(value.size()) + " elements";
  if (value.is_object()) return "an object of " + std::to_string(value.size()) + " members";
  std::string text = value.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  if (text.size() > max_chars) text = text.substr(0, max_chars) + "...";
  return text;
}

}  // namespace dfsm
