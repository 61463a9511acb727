// Numbers in the messages of the sparse stage and of the checks on its
// results (warnings, errors, reasons).
#pragma once

#include <cstdio>
#include <string>

namespace dfsm {

// `value` in fixed notation with `digits` after the point ("%.*f", C locale):
// FixedText(1.2345) == "1.23".
inline std::string FixedText(double value, int digits = 2) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", digits, value);
  return text;
}

}  // namespace dfsm
