// What the harnesses share: a check that crashes the fuzzer with a message
// (an assertion the harness makes about the code under test, kept in release
// builds), and a view of the input as text.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

// Aborts, so libFuzzer records the input as a crash, when `condition` is false.
#define FUZZ_CHECK(condition, message)                                                           \
  do {                                                                                           \
    if (!(condition)) {                                                                          \
      std::fprintf(stderr, "%s:%d: FUZZ_CHECK(%s) failed: %s\n", __FILE__, __LINE__, #condition, \
                   std::string(message).c_str());                                                \
      std::abort();                                                                              \
    }                                                                                            \
  } while (0)

namespace dfsm::fuzz {

inline std::string AsText(const uint8_t* data, size_t size) {
  return std::string(reinterpret_cast<const char*>(data), size);
}

// A rejection must say what is wrong: an empty message helps nobody.
inline void CheckNamedError(const std::exception& error) {
  FUZZ_CHECK(error.what() != nullptr && error.what()[0] != '\0', "an error without a message");
}

}  // namespace dfsm::fuzz
