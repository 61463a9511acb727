// What the fault and soak tests of dfsmd share: a generated burst on disk,
// triggering and awaiting jobs over HTTP, and checking that a finished job
// serves a complete result.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "dfsmd/dfsmd_process.h"

namespace dfsm::test {

// A 320x240 10-frame burst with ground truth, written to `dir` (seed 3: the
// burst the other daemon tests use).
void WriteTestBurst(const std::filesystem::path& dir);

// The Location of a 202 answer ("" and a test failure otherwise).
std::string AcceptedLocation(const httplib::Result& result);

// Polls a job until it is succeeded or failed (a test failure after `timeout`).
nlohmann::json AwaitFinished(httplib::Client& client, const std::string& location,
                             std::chrono::seconds timeout = std::chrono::seconds(120));

// Checks what a listed job serves: a succeeded job every file it links, each
// complete (result.json parses with status ok, depth.tiff decodes to the burst's
// size, PNGs decode, PLYs carry their header and as many bytes as it promises);
// an unfinished one 409 for its files; a failed one its reason. Returns the
// number of files checked.
int ExpectCompleteResult(httplib::Client& client, const nlohmann::json& job, int width, int height);

}  // namespace dfsm::test
