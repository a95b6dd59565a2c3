// A real dysa-server process for the fault and soak suite (tests/soak/soak_cases.h), without
// GoogleTest so that bench/soak_bench shares it: started on 127.0.0.1 and a free port (announced
// through --port-file), measured through /proc, and stopped with a signal.
#pragma once

#include <sys/types.h>

#include <filesystem>
#include <string>
#include <vector>

namespace dysa::soak {

// Starts `program args...` with stdout and stderr appended to `log` and stdin from /dev/null;
// returns its pid (the child exits 127 if `program` cannot be run).
pid_t SpawnProcess(const std::string& program, const std::vector<std::string>& args,
                   const std::filesystem::path& log);

// The resident memory of process `pid` (VmRSS of /proc/PID/status), bytes; 0 if it has none.
size_t ResidentBytes(pid_t pid);

class SoakServer {
 public:
  // Starts `binary` with `args` plus --listen 127.0.0.1:0, --port-file and --threads 1, its log
  // in `dir`/server.log. running() is false (and error() says why) if it announced no port within
  // 60 s or exited at start.
  SoakServer(const std::string& binary, const std::filesystem::path& dir,
             std::vector<std::string> args);
  // Kills a server still running (SIGKILL): a case that stops it checks how it stops.
  ~SoakServer();
  SoakServer(const SoakServer&) = delete;
  SoakServer& operator=(const SoakServer&) = delete;

  bool running() const { return pid_ > 0 && !address_.empty(); }
  const std::string& error() const { return error_; }
  const std::string& address() const { return address_; }
  pid_t pid() const { return pid_; }
  size_t resident_bytes() const { return ResidentBytes(pid_); }
  std::string log() const;

  // Sends `signal` and waits for the exit; returns the seconds from the signal to the exit, and
  // its exit status in `exit_status` (-1: killed by a signal). After `give_up` seconds it kills the
  // server (SIGKILL) and returns `give_up`.
  double StopTimed(int signal, double give_up, int& exit_status);

 private:
  std::filesystem::path log_;
  pid_t pid_ = -1;
  std::string address_;
  std::string error_;
};

}  // namespace dysa::soak
