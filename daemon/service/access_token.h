// Where dfsmd's bearer token comes from and when one is required.
//
// The API is open only on a loopback address: any other `server.listen`
// (0.0.0.0, ::, a LAN address, a host name) makes the token mandatory, and the
// daemon refuses to start without one rather than serving a camera and its
// job store to the network unauthenticated. The token is read from
// `server.token_file`, or else from systemd's credentials
// ($CREDENTIALS_DIRECTORY/<server.token_credential>, set by LoadCredential=),
// which keeps it out of the unit, the command line and the environment.
#pragma once

#include <filesystem>
#include <string>

#include "daemon/service/config.h"

namespace dfsm::service {

// Shortest accepted token: 16 characters of any printable alphabet is far
// beyond online guessing; `openssl rand -hex 32` gives 64.
inline constexpr size_t kMinTokenLength = 16;
// Longest: the token travels in one header line, which httplib caps at 8 KiB.
inline constexpr size_t kMaxTokenLength = 4096;

// True for 127.0.0.0/8, ::1, ::ffff:127.x.x.x and "localhost". Any other
// name is not loopback: it may resolve to anything.
bool IsLoopbackAddress(const std::string& listen);

// Reads a token file: one line of printable ASCII without spaces, a trailing
// newline stripped. Throws ConfigError prefixed with `key` when the file is
// unreadable, readable by every user (a token file must not be), empty, too
// short or too long, or contains other characters.
std::string ReadTokenFile(const std::filesystem::path& path, const std::string& key);

// Sets server->token from server->token_file, else from the credential named
// server->token_credential in `credentials_directory` (empty or null: none),
// and enforces the rule above. Throws ConfigError.
void ResolveAccessToken(ServerConfig* server, const char* credentials_directory);

}  // namespace dfsm::service
