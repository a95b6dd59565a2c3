// When the viewer should give up and exit by itself rather than spin on: a viewer left behind
// (its server gone for good, or, in --screenshot mode, the process that started it gone, or the
// screenshot overdue) exits with a message naming why, within a few seconds. A --screenshot run
// is driven by a script or a test; when they die, nothing is left to read its PNG.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <optional>
#include <string>

namespace dysa::viewer {

struct WatchOptions {
  bool screenshot = false;
  // s without a connection, after having had one, before giving up; 0: wait for the server to
  // come back however long it takes.
  double server_timeout = 5;
  // s from the start for --screenshot to be written; 0: no limit.
  double screenshot_timeout = 60;
};

class SessionWatch {
 public:
  using Clock = std::chrono::steady_clock;

  // `parent`: the pid the viewer was started by (getppid() at start).
  SessionWatch(WatchOptions options, pid_t parent, Clock::time_point start);

  // Once a frame: whether the link to the server is up, whether the screenshot still waits
  // (`waiting_for`: what it waits for, e.g. "a particle frame"; empty: nothing), and the pid
  // of the viewer's parent now. Returns why to give up, or nothing.
  std::optional<std::string> Check(Clock::time_point now, bool connected,
                                   const std::string& connection_error,
                                   const std::string& waiting_for, pid_t parent_now);

 private:
  WatchOptions options_;
  pid_t parent_;
  Clock::time_point start_;
  bool was_connected_ = false;
  std::optional<Clock::time_point> lost_since_;
};

// In --screenshot mode: asks the kernel to send SIGTERM when the parent exits
// (PR_SET_PDEATHSIG), so that an orphaned viewer ends even while it blocks in a driver call.
// Returns the parent's pid.
pid_t WatchParent();

}  // namespace dysa::viewer
