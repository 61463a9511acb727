// Locating the shared development data from tests: ../shared relative to the
// repository root (DFSM_SHARED_DIR), skipped with a message where it is absent.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

namespace dfsm::testing {

inline std::filesystem::path SharedData(const std::string& name) {
  return std::filesystem::path(DFSM_SHARED_DIR) / "data" / name;
}

}  // namespace dfsm::testing

// Skips the current test when a shared data set is missing.
#define DFSM_REQUIRE_SHARED_DATA(name)                                                 \
  do {                                                                                 \
    if (!std::filesystem::exists(::dfsm::testing::SharedData(name) / "manifest.json")) \
      GTEST_SKIP() << "shared data set '" << name << "' not found at "                 \
                   << ::dfsm::testing::SharedData(name)                                \
                   << " (it lives in ../shared/data beside the repository)";           \
  } while (0)
