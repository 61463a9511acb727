#include "daemon/service/access_token.h"

#include <arpa/inet.h>
#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

namespace dfsm::service {
namespace fs = std::filesystem;

bool IsLoopbackAddress(const std::string& listen) {
  if (listen == "localhost") return true;
  in_addr v4{};
  if (::inet_pton(AF_INET, listen.c_str(), &v4) == 1) {
    return (ntohl(v4.s_addr) >> 24) == 127;
  }
  // An IPv6 literal, with or without the brackets of URL notation.
  std::string text = listen;
  if (text.size() > 2 && text.front() == '[' && text.back() == ']') {
    text = text.substr(1, text.size() - 2);
  }
  in6_addr v6{};
  if (::inet_pton(AF_INET6, text.c_str(), &v6) != 1) return false;
  if (IN6_IS_ADDR_LOOPBACK(&v6)) return true;
  return IN6_IS_ADDR_V4MAPPED(&v6) && v6.s6_addr[12] == 127;
}

std::string ReadTokenFile(const fs::path& path, const std::string& key) {
  const std::string where = key + ": '" + path.string() + "'";
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0) {
    throw ConfigError(where + ": cannot read the token file: " + std::strerror(errno));
  }
  if (!S_ISREG(info.st_mode)) throw ConfigError(where + ": the token file is not a regular file");
  if (info.st_mode & S_IROTH) {
    throw ConfigError(where + ": the token file is readable by every user; chmod o-rwx it");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ConfigError(where + ": cannot read the token file: " + std::strerror(errno));
  std::ostringstream content;
  content << in.rdbuf();
  std::string token = content.str();
  // Editors and `echo` end the file with a newline; it is not part of the token.
  if (!token.empty() && token.back() == '\n') token.pop_back();
  if (!token.empty() && token.back() == '\r') token.pop_back();
  if (token.empty()) throw ConfigError(where + ": the token file is empty");
  for (const char c : token) {
    if (c < 0x21 || c > 0x7e) {
      throw ConfigError(where +
                        ": the token must be one line of printable ASCII without spaces "
                        "(e.g. from `openssl rand -hex 32`)");
    }
  }
  if (token.size() < kMinTokenLength) {
    throw ConfigError(where + ": the token has " + std::to_string(token.size()) +
                      " characters; at least " + std::to_string(kMinTokenLength) + " are required");
  }
  if (token.size() > kMaxTokenLength) {
    throw ConfigError(where + ": the token is longer than " + std::to_string(kMaxTokenLength) +
                      " characters");
  }
  return token;
}

void ResolveAccessToken(ServerConfig* server, const char* credentials_directory) {
  server->token.clear();
  if (!server->token_file.empty()) {
    server->token = ReadTokenFile(server->token_file, "server.token_file");
  } else if (credentials_directory && *credentials_directory && !server->token_credential.empty()) {
    // Only a credential that systemd actually passed counts; its absence is
    // judged by the loopback rule below, like a missing token_file.
    const fs::path path = fs::path(credentials_directory) / server->token_credential;
    std::error_code error;
    if (fs::exists(path, error)) {
      server->token = ReadTokenFile(path, "server.token_credential");
    }
  }
  if (server->token.empty() && !IsLoopbackAddress(server->listen)) {
    throw ConfigError("server.listen: '" + server->listen +
                      "' is not a loopback address, so a bearer token is required and none is "
                      "configured; set server.token_file, or pass the credential '" +
                      server->token_credential +
                      "' with LoadCredential= (docs/daemon.md, Security)");
  }
}

}  // namespace dfsm::service
