// What the HTTP harnesses (http_fuzzer.cc in process, http_socket_fuzzer.cc
// through a real socket) share: the fixture-id substitution of their inputs
// and the checks on dfsmd's answers.
#pragma once

#include <string>
#include <string_view>

#include "fuzz/fuzz_daemon.h"

namespace dfsm::fuzz {

// "{J0}".."{J3}" in `input` -> the fixture jobs' ids.
std::string SubstituteFixtures(std::string_view input, const FuzzDaemon& daemon);

// Checks one answer: its final status line (after any "100 Continue"), no
// 500 (an exception escaping a handler is a bug), and problem+json for every
// error. Returns the bytes after it when its length is known (Content-Length),
// "" otherwise.
std::string CheckResponse(const std::string& response);

// Checks every answer in `bytes` (pipelined requests give several).
void CheckResponses(std::string bytes);

}  // namespace dfsm::fuzz
