#include "soak/soak_server.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <thread>

#include "support/die_with_parent.h"

namespace dysa::soak {

pid_t SpawnProcess(const std::string& program, const std::vector<std::string>& args,
                   const std::filesystem::path& log) {
  std::vector<std::string> argv_strings = {program};
  argv_strings.insert(argv_strings.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& s : argv_strings) argv.push_back(s.data());
  argv.push_back(nullptr);
  const pid_t pid = fork();
  if (pid == 0) {
    // Only async-signal-safe calls between fork and exec: the parent has gRPC threads.
    dysa::testing::DieWithParent();
    const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    const int null = open("/dev/null", O_RDONLY);
    if (fd >= 0) dup2(fd, STDOUT_FILENO), dup2(fd, STDERR_FILENO);
    if (null >= 0) dup2(null, STDIN_FILENO);
    execv(program.c_str(), argv.data());
    _exit(127);
  }
  return pid;
}

size_t ResidentBytes(pid_t pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return size_t(std::stoull(line.substr(6))) * 1024;
  }
  return 0;
}

SoakServer::SoakServer(const std::string& binary, const std::filesystem::path& dir,
                       std::vector<std::string> args)
    : log_(dir / "server.log") {
  const std::filesystem::path port_file = dir / "port";
  std::filesystem::remove(port_file);
  args.insert(args.end(),
              {"--listen", "127.0.0.1:0", "--port-file", port_file.string(), "--threads", "1"});
  pid_ = SpawnProcess(binary, args, log_);
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (std::chrono::steady_clock::now() < give_up) {
    int status = 0;
    if (waitpid(pid_, &status, WNOHANG) == pid_) {
      pid_ = -1;
      error_ = "dysa-server exited at start:\n" + log();
      return;
    }
    std::ifstream in(port_file);
    int port = 0;
    if (in >> port && port > 0) {
      address_ = "127.0.0.1:" + std::to_string(port);
      return;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  error_ = "dysa-server wrote no port file within 60 s:\n" + log();
}

SoakServer::~SoakServer() {
  if (pid_ <= 0) return;
  kill(pid_, SIGKILL);
  waitpid(pid_, nullptr, 0);
}

std::string SoakServer::log() const {
  std::ifstream file(log_, std::ios::binary);
  std::stringstream text;
  text << file.rdbuf();
  return text.str();
}

double SoakServer::StopTimed(int signal, double give_up, int& exit_status) {
  exit_status = -1;
  if (pid_ <= 0) return 0;
  const auto start = std::chrono::steady_clock::now();
  const auto seconds = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  kill(pid_, signal);
  int status = 0;
  double took = 0;
  while (waitpid(pid_, &status, WNOHANG) != pid_) {
    if (seconds() > give_up) {
      kill(pid_, SIGKILL);
      waitpid(pid_, &status, 0);
      pid_ = -1;
      return give_up;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  took = seconds();
  pid_ = -1;
  if (WIFEXITED(status)) exit_status = WEXITSTATUS(status);
  return took;
}

}  // namespace dysa::soak
