// dysa-delay-relay (tests/link/delay_relay_main.cc) as a child process for tests: started with
// the given flags plus a --port-file in `dir`, so a --listen port of 0 works; stopped with
// SIGTERM (then SIGKILL after 5 s) by Stop() or the destructor, and waited for.
#pragma once

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "support/server_process.h"  // Spawn
#include "support/temp_dir.h"        // ReadFile

namespace dysa::testing {

class RelayProcess {
 public:
  RelayProcess(const std::string& binary, const std::filesystem::path& dir,
               std::vector<std::string> args)
      : log_(dir / "relay.log") {
    const std::filesystem::path port_file = dir / "relay.port";
    std::filesystem::remove(port_file);
    args.insert(args.end(), {"--port-file", port_file.string()});
    pid_ = Spawn(binary, args, log_);
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (std::chrono::steady_clock::now() < give_up) {
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        exit_status_ = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
        return;  // log() says why
      }
      std::ifstream in(port_file);
      if (in >> port_ && port_ > 0) return;
      port_ = 0;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }
  ~RelayProcess() { Stop(); }
  RelayProcess(const RelayProcess&) = delete;
  RelayProcess& operator=(const RelayProcess&) = delete;

  // SIGTERM, then the exit status (0 for a clean shutdown; -1 when it had to be killed). Again
  // after the first: the same status.
  int Stop() {
    if (pid_ <= 0) return exit_status_;
    kill(pid_, SIGTERM);
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    int status = 0;
    while (waitpid(pid_, &status, WNOHANG) != pid_) {
      if (std::chrono::steady_clock::now() > give_up) {
        kill(pid_, SIGKILL);
        waitpid(pid_, &status, 0);
        status = -1;
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    pid_ = -1;
    exit_status_ = status != -1 && WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    return exit_status_;
  }

  bool running() const { return pid_ > 0 && port_ > 0; }
  int port() const { return port_; }
  pid_t pid() const { return pid_; }
  // When it exited at start (a bad flag): its status.
  int exit_status() const { return exit_status_; }
  std::string log() const { return ReadFile(log_); }

 private:
  std::filesystem::path log_;
  pid_t pid_ = -1;
  int port_ = 0;
  int exit_status_ = -1;
};

}  // namespace dysa::testing
