// A network namespace of its own whose loopback is a shaped link (tc's token bucket filter), for
// tests that run a real dysa-server and its client over a link of known rate. Needs root and
// iproute2's `ip` and `tc`; where any is missing, or the namespace cannot be made, available()
// is false and skip_reason() says what is missing. The namespace is removed by the destructor.
#pragma once

#include <fcntl.h>
#include <sched.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

namespace dysa::testing {

// The first of `names` that is an executable file, or "" if none is.
inline std::string FindExecutable(const std::vector<std::string>& names) {
  for (const std::string& name : names) {
    if (access(name.c_str(), X_OK) == 0) return name;
  }
  return "";
}

// Runs `argv` (no shell), its stdout and stderr appended to `output`; returns its exit status
// (-1 if it did not exit normally or could not be started).
inline int RunCommand(const std::vector<std::string>& argv, std::string& output) {
  int pipe_fds[2];
  if (pipe(pipe_fds) != 0) return -1;
  const pid_t pid = fork();
  if (pid == 0) {
    dup2(pipe_fds[1], STDOUT_FILENO);
    dup2(pipe_fds[1], STDERR_FILENO);
    close(pipe_fds[0]);
    close(pipe_fds[1]);
    std::vector<char*> args;
    for (const std::string& s : argv) args.push_back(const_cast<char*>(s.c_str()));
    args.push_back(nullptr);
    execv(args[0], args.data());
    _exit(127);
  }
  close(pipe_fds[1]);
  char buffer[512];
  ssize_t n = 0;
  while ((n = read(pipe_fds[0], buffer, sizeof buffer)) > 0) output.append(buffer, size_t(n));
  close(pipe_fds[0]);
  int status = 0;
  if (pid < 0 || waitpid(pid, &status, 0) != pid) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

class LinkNamespace {
 public:
  // A namespace named `name` whose `lo` has MTU 1500 (loopback's 64 KiB packets would exceed the
  // bucket) and a token bucket of `rate` (tc's syntax: "100mbit", "1gbit"). An empty `rate`: an
  // unshaped namespace (its lo up as it comes, no qdisc), for a server that a relay
  // (delay_relay.h) joins to a shaped one.
  LinkNamespace(const std::string& name, const std::string& rate) : name_(name) {
    skip_reason_ = Setup(rate);
    available_ = skip_reason_.empty();
  }
  ~LinkNamespace() {
    if (!created_) return;
    std::string output;
    RunCommand({ip_, "netns", "del", name_}, output);
  }
  LinkNamespace(const LinkNamespace&) = delete;
  LinkNamespace& operator=(const LinkNamespace&) = delete;

  bool available() const { return available_; }
  const std::string& skip_reason() const { return skip_reason_; }
  const std::string& name() const { return name_; }
  const std::string& ip() const { return ip_; }

  // The command line that runs `argv` inside the namespace: `ip netns exec NAME argv...` (ip
  // execs it, so its pid is the program's).
  std::vector<std::string> Wrap(const std::vector<std::string>& argv) const {
    std::vector<std::string> wrapped = {"netns", "exec", name_};
    wrapped.insert(wrapped.end(), argv.begin(), argv.end());
    return wrapped;
  }
  // Moves the calling process into the namespace; for a freshly forked, single-threaded child
  // (a thread's namespace is its own, and new threads inherit their creator's). False on failure.
  bool Enter() const {
    const int fd = open(("/var/run/netns/" + name_).c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return false;
    const bool entered = setns(fd, CLONE_NEWNET) == 0;
    close(fd);
    return entered;
  }

 private:
  // Makes the namespace and shapes its lo; "" when done, otherwise what is missing.
  std::string Setup(const std::string& rate) {
    ip_ = FindExecutable({"/usr/sbin/ip", "/sbin/ip", "/usr/bin/ip", "/bin/ip"});
    tc_ = FindExecutable({"/usr/sbin/tc", "/sbin/tc", "/usr/bin/tc", "/bin/tc"});
    if (ip_.empty()) return "iproute2's `ip` is not installed";
    if (tc_.empty()) return "iproute2's `tc` is not installed";
    if (geteuid() != 0) return "making a network namespace needs root";
    std::string output;
    RunCommand({ip_, "netns", "del", name_}, output);  // a leftover of a killed run
    output.clear();
    if (RunCommand({ip_, "netns", "add", name_}, output) != 0) {
      return "`ip netns add` failed: " + output;
    }
    created_ = true;
    if (rate.empty()) {
      if (Exec({ip_, "link", "set", "lo", "up"}, output) != 0) {
        return "cannot bring up the namespace's lo: " + output;
      }
      return "";
    }
    if (Exec({ip_, "link", "set", "lo", "mtu", "1500", "up"}, output) != 0) {
      return "cannot bring up the namespace's lo at MTU 1500: " + output;
    }
    if (Exec({tc_, "qdisc", "add", "dev", "lo", "root", "tbf", "rate", rate, "burst", "64kb",
              "latency", "100ms"},
             output) != 0) {
      return "`tc qdisc add ... tbf` failed (no sch_tbf?): " + output;
    }
    return "";
  }
  int Exec(const std::vector<std::string>& argv, std::string& output) const {
    std::vector<std::string> full = {ip_};
    for (const std::string& s : Wrap(argv)) full.push_back(s);
    return RunCommand(full, output);
  }

  std::string name_;
  std::string ip_;
  std::string tc_;
  std::string skip_reason_;
  bool created_ = false;
  bool available_ = false;
};

}  // namespace dysa::testing
