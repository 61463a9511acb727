// Errors as RFC 9457 problem details (application/problem+json): a stable
// machine-readable `type`, a short `title` naming the problem and a `detail`
// sentence a user can act on.
#pragma once

#include <httplib.h>

#include <filesystem>
#include <string>

namespace dfsm::api {

inline constexpr const char* kProblemContentType = "application/problem+json";
inline constexpr const char* kJsonContentType = "application/json";

// The JSON text of a problem (what SetProblem sends).
std::string ProblemBody(int status, const std::string& slug, const std::string& title,
                        const std::string& detail);

// The standard title of an HTTP status dfsmd answers on its own (reason phrase).
const char* StatusTitle(int status);

// `slug` becomes the type "urn:dfsm:problem:<slug>" (e.g. "queue-full").
void SetProblem(httplib::Response& response, int status, const std::string& slug,
                const std::string& title, const std::string& detail);

// `detail` with every mention of the state directory (as configured or as
// resolved) written "<state_dir>": a client learns which file, not where the
// daemon keeps its state.
std::string HideStateDirectory(std::string detail, const std::filesystem::path& state_dir);

// A problem body for a status that httplib produced on its own (404 of an
// unknown path, 413 of an oversized body, 400 of a malformed request).
void SetDefaultProblem(const httplib::Request& request, httplib::Response& response,
                       size_t max_body_bytes);

}  // namespace dfsm::api
