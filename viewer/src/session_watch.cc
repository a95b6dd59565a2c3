#include "session_watch.h"

#include <signal.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <cstdio>

namespace dysa::viewer {

namespace {
std::string Seconds(double s) {
  char text[32];
  std::snprintf(text, sizeof text, "%.0f s", s);
  return text;
}
}  // namespace

SessionWatch::SessionWatch(WatchOptions options, pid_t parent, Clock::time_point start)
    : options_(options), parent_(parent), start_(start) {}

std::optional<std::string> SessionWatch::Check(Clock::time_point now, bool connected,
                                               const std::string& connection_error,
                                               const std::string& waiting_for, pid_t parent_now) {
  if (options_.screenshot && parent_now != parent_) {
    return "the process that started it (pid " + std::to_string(parent_) +
           ") is gone; no one is left to read the screenshot";
  }
  if (connected) {
    was_connected_ = true;
    lost_since_.reset();
  } else if (was_connected_) {
    if (!lost_since_) lost_since_ = now;
    const double lost = std::chrono::duration<double>(now - *lost_since_).count();
    if (options_.server_timeout > 0 && lost > options_.server_timeout) {
      return "lost the server for " + Seconds(lost) +
             (connection_error.empty() ? "" : " (" + connection_error + ")") +
             "; --server-timeout 0 waits for it to come back";
    }
  }
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  if (options_.screenshot && !waiting_for.empty() && options_.screenshot_timeout > 0 &&
      elapsed > options_.screenshot_timeout) {
    std::string why = "no " + waiting_for + " within " + Seconds(options_.screenshot_timeout);
    if (!connected && !connection_error.empty()) why += ": " + connection_error;
    return why;
  }
  return std::nullopt;
}

pid_t WatchParent() {
  const pid_t parent = getppid();
  prctl(PR_SET_PDEATHSIG, SIGTERM);
  return parent;
}

}  // namespace dysa::viewer
