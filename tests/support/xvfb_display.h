// A private X server (Xvfb) for tests that open windows: Xvfb picks a free display number
// itself (-displayfd), so tests running in parallel never race for one.
#pragma once

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <string>

#include "support/die_with_parent.h"

namespace dysa::testing {

class XvfbDisplay {
 public:
  explicit XvfbDisplay(const std::string& screen = "1280x800x24") {
    int fds[2];
    if (pipe(fds) != 0) {
      ADD_FAILURE() << "pipe() failed";
      return;
    }
    pid_ = fork();
    if (pid_ == 0) {
      DieWithParent();
      close(fds[0]);
      const std::string fd = std::to_string(fds[1]);
      execlp("Xvfb", "Xvfb", "-displayfd", fd.c_str(), "-screen", "0", screen.c_str(), "-nolisten",
             "tcp", "-noreset", static_cast<char*>(nullptr));
      _exit(127);
    }
    close(fds[1]);
    // Xvfb writes the display number and a newline once it accepts connections.
    std::string number;
    char c;
    while (read(fds[0], &c, 1) == 1 && c != '\n') number += c;
    close(fds[0]);
    if (number.empty()) {
      ADD_FAILURE() << "Xvfb did not start (is the xvfb package installed?)";
      return;
    }
    display_ = ":" + number;
  }
  ~XvfbDisplay() {
    if (pid_ > 0) {
      kill(pid_, SIGTERM);
      waitpid(pid_, nullptr, 0);
    }
  }
  XvfbDisplay(const XvfbDisplay&) = delete;
  XvfbDisplay& operator=(const XvfbDisplay&) = delete;

  const std::string& display() const { return display_; }  // e.g. ":99"; empty on failure

 private:
  pid_t pid_ = -1;
  std::string display_;
};

}  // namespace dysa::testing
