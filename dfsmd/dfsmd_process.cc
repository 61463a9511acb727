#include "dfsmd/dfsmd_process.h"

#include <fcntl.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <nlohmann/json.hpp>

namespace dfsm::test {
namespace {

pid_t Spawn(const std::string& binary, const std::vector<std::string>& args,
            const std::filesystem::path& log, const std::map<std::string, std::string>& env) {
  std::vector<char*> argv;
  argv.push_back(const_cast<char*>(binary.c_str()));
  for (const std::string& arg : args) argv.push_back(const_cast<char*>(arg.c_str()));
  argv.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    if (fd >= 0) {
      ::dup2(fd, 1);
      ::dup2(fd, 2);
    }
    // Not under systemd: no readiness or watchdog socket.
    ::unsetenv("NOTIFY_SOCKET");
    ::unsetenv("WATCHDOG_USEC");
    for (const auto& [name, value] : env) ::setenv(name.c_str(), value.c_str(), 1);
    ::execv(binary.c_str(), argv.data());
    ::_exit(127);
  }
  return pid;
}

int WaitExit(pid_t pid, std::chrono::seconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    int status = 0;
    const pid_t done = ::waitpid(pid, &status, WNOHANG);
    if (done == pid) {
      if (WIFEXITED(status)) return WEXITSTATUS(status);
      if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return -1;
}

}  // namespace

int FreeLoopbackPort() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = 0;
  socklen_t length = sizeof(address);
  int port = 0;
  if (::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0 &&
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) == 0) {
    port = ntohs(address.sin_port);
  }
  ::close(fd);
  return port;
}

DfsmdProcess::DfsmdProcess(const std::string& binary, std::vector<std::string> args,
                           const std::filesystem::path& log,
                           const std::map<std::string, std::string>& env, bool wait_streaming)
    : port_(FreeLoopbackPort()), log_(log) {
  args.push_back("--server.port");
  args.push_back(std::to_string(port_));
  pid_ = Spawn(binary, args, log, env);
  httplib::Client client = Client();
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (std::chrono::steady_clock::now() < deadline) {
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) == pid_) {
      pid_ = -1;
      return;
    }
    if (!wait_streaming) {
      if (auto health = client.Get("/healthz"); health && health->status == 200) {
        ready_ = true;
        return;
      }
    } else if (auto camera = client.Get("/api/v1/camera"); camera && camera->status == 200) {
      if (nlohmann::json::parse(camera->body).value("streaming", false)) {
        ready_ = true;
        return;
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

DfsmdProcess::~DfsmdProcess() {
  if (pid_ > 0) Stop(SIGKILL);
}

httplib::Client DfsmdProcess::Client() const {
  httplib::Client client("127.0.0.1", port_);
  client.set_connection_timeout(std::chrono::seconds(5));
  client.set_read_timeout(std::chrono::seconds(30));
  return client;
}

std::string DfsmdProcess::Log() const {
  try {
    return ReadFileToString(log_);
  } catch (const std::exception&) {
    return "";
  }
}

int DfsmdProcess::Stop(int signal, std::chrono::seconds timeout) {
  if (pid_ <= 0) return -1;
  ::kill(pid_, signal);
  const int status = WaitExit(pid_, timeout);
  if (status >= 0) pid_ = -1;
  return status;
}

int RunDfsmd(const std::string& binary, const std::vector<std::string>& args,
             const std::filesystem::path& log) {
  const pid_t pid = Spawn(binary, args, log, {});
  const int status = WaitExit(pid, std::chrono::seconds(20));
  if (status < 0) {
    ::kill(pid, SIGKILL);
    WaitExit(pid, std::chrono::seconds(5));
  }
  return status;
}

}  // namespace dfsm::test
