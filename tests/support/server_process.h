// A real dysa-server as a child process for integration tests: started on 127.0.0.1 and a free
// port (announced through --port-file), stopped with a signal that it must answer by exiting 0.
#pragma once

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "support/die_with_parent.h"
#include "support/temp_dir.h"

namespace dysa::testing {

// Starts `program args...` with stdout and stderr appended to `log`; returns its pid.
inline pid_t Spawn(const std::string& program, const std::vector<std::string>& args,
                   const std::filesystem::path& log) {
  std::vector<std::string> argv_strings = {program};
  argv_strings.insert(argv_strings.end(), args.begin(), args.end());
  const pid_t pid = fork();
  if (pid == 0) {
    DieWithParent();
    const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    const int null = open("/dev/null", O_RDONLY);
    if (fd >= 0) dup2(fd, STDOUT_FILENO), dup2(fd, STDERR_FILENO);
    if (null >= 0) dup2(null, STDIN_FILENO);
    // The tests pass tokens and addresses explicitly.
    unsetenv("DYSA_TOKEN");
    unsetenv("DYSA_SERVER");
    std::vector<char*> argv;
    for (std::string& s : argv_strings) argv.push_back(s.data());
    argv.push_back(nullptr);
    execv(program.c_str(), argv.data());
    _exit(127);
  }
  return pid;
}

// Exit status of a finished child; -1 when it did not exit normally (a signal).
inline int WaitExit(pid_t pid) {
  int status = 0;
  if (waitpid(pid, &status, 0) != pid) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// A dysa-server on 127.0.0.1, stopped with SIGTERM by Stop() or the destructor. `port` 0 picks
// a free one; a given port lets a test restart a server where clients expect it.
class ServerProcess {
 public:
  ServerProcess(const std::string& binary, const std::filesystem::path& dir,
                std::vector<std::string> args, int port = 0)
      : log_(dir / "server.log") {
    const std::filesystem::path port_file = dir / "port";
    std::filesystem::remove(port_file);  // a previous server's
    args.insert(args.end(), {"--listen", "127.0.0.1:" + std::to_string(port), "--port-file",
                             port_file.string(), "--threads", "1"});
    pid_ = Spawn(binary, args, log_);
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (std::chrono::steady_clock::now() < give_up) {
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        ADD_FAILURE() << "dysa-server exited at start:\n" << ReadFile(log_);
        return;
      }
      std::ifstream in(port_file);
      int announced = 0;
      if (in >> announced && announced > 0) {
        port_ = announced;
        address_ = "127.0.0.1:" + std::to_string(announced);
        return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    ADD_FAILURE() << "dysa-server wrote no port file within 60 s:\n" << ReadFile(log_);
  }
  ~ServerProcess() {
    if (pid_ > 0) Stop();
  }
  ServerProcess(const ServerProcess&) = delete;
  ServerProcess& operator=(const ServerProcess&) = delete;

  // SIGTERM (or SIGINT, Ctrl-C); the server must shut down gracefully (exit status 0).
  void Stop(int signal = SIGTERM) {
    if (pid_ <= 0) return;
    kill(pid_, signal);
    EXPECT_EQ(WaitExit(pid_), 0) << ReadFile(log_);
    pid_ = -1;
  }
  // Sends `signal` and waits for the exit, which must be status 0; returns the seconds from the
  // signal to the exit. After `give_up` seconds it kills the server (SIGKILL) and fails.
  double StopTimed(int signal, double give_up) {
    if (pid_ <= 0) return 0;
    const auto start = std::chrono::steady_clock::now();
    const auto seconds = [&] {
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    };
    kill(pid_, signal);
    int status = 0;
    while (waitpid(pid_, &status, WNOHANG) != pid_) {
      if (seconds() > give_up) {
        kill(pid_, SIGKILL);
        waitpid(pid_, &status, 0);
        ADD_FAILURE() << "dysa-server still ran " << give_up << " s after the signal:\n"
                      << ReadFile(log_);
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    const double took = seconds();
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << ReadFile(log_);
    pid_ = -1;
    return took;
  }
  pid_t pid() const { return pid_; }
  const std::string& address() const { return address_; }
  int port() const { return port_; }
  bool running() const { return !address_.empty(); }
  std::string log() const { return ReadFile(log_); }

 private:
  std::filesystem::path log_;
  pid_t pid_ = -1;
  int port_ = 0;
  std::string address_;
};

}  // namespace dysa::testing
