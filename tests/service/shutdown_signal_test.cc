// Tests of dysa/service/shutdown_signal.h in forked children (the bound ends the process): after
// SIGTERM the process exits at the bound if the orderly shutdown has not finished, at once on a
// second signal, and not at all once disarmed.
#include "dysa/service/shutdown_signal.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <string>
#include <thread>

#include "support/die_with_parent.h"

namespace dysa::service {
namespace {

using std::chrono::milliseconds;

struct Child {
  int exit_status = -1;  // -1: did not exit normally
  double seconds = 0;    // from its start to its exit
  std::string log;       // what it logged
};

// Runs `body` in a forked child whose log lines go to a pipe; waits at most 60 s (then kills it).
// The test process has no other thread when it forks: the child may start its own.
template <class Body>
Child RunChild(Body body) {
  int pipe_fds[2];
  EXPECT_EQ(pipe(pipe_fds), 0);
  const auto start = std::chrono::steady_clock::now();
  const pid_t pid = fork();
  if (pid == 0) {
    dysa::testing::DieWithParent();
    close(pipe_fds[0]);
    FILE* log = fdopen(pipe_fds[1], "w");
    body([log](const std::string& line) {
      std::fprintf(log, "%s\n", line.c_str());
      std::fflush(log);
    });
    _exit(7);  // the body returned: the bound did not end it
  }
  close(pipe_fds[1]);
  Child child;
  int status = 0;
  while (waitpid(pid, &status, WNOHANG) != pid) {
    if (std::chrono::steady_clock::now() - start > std::chrono::seconds(60)) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      break;
    }
    std::this_thread::sleep_for(milliseconds(1));
  }
  child.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (WIFEXITED(status)) child.exit_status = WEXITSTATUS(status);
  char buffer[4096];
  ssize_t n = 0;
  while ((n = read(pipe_fds[0], buffer, sizeof(buffer))) > 0) child.log.append(buffer, size_t(n));
  close(pipe_fds[0]);
  return child;
}

// A shutdown that never finishes (a solver step of minutes): the bound ends the process.
TEST(ShutdownSignalTest, AShutdownThatDoesNotFinishIsEndedAtTheBound) {
  const Child child = RunChild([](auto log) {
    ShutdownSignal signals(milliseconds(300), log);
    kill(getpid(), SIGTERM);
    log("waited for " + signals.Wait());
    std::this_thread::sleep_for(std::chrono::seconds(30));
  });
  EXPECT_EQ(child.exit_status, 0) << child.log;
  EXPECT_LT(child.seconds, 10) << child.log;  // not the 30 s it would take
  EXPECT_NE(child.log.find("waited for SIGTERM"), std::string::npos) << child.log;
  EXPECT_NE(child.log.find("did not finish within 300 ms"), std::string::npos) << child.log;
}

TEST(ShutdownSignalTest, ASecondSignalEndsTheProcessAtOnce) {
  const Child child = RunChild([](auto log) {
    ShutdownSignal signals(milliseconds(60'000), log);
    kill(getpid(), SIGINT);
    log("waited for " + signals.Wait());
    kill(getpid(), SIGTERM);
    std::this_thread::sleep_for(std::chrono::seconds(30));
  });
  EXPECT_EQ(child.exit_status, 0) << child.log;
  EXPECT_LT(child.seconds, 10) << child.log;
  EXPECT_NE(child.log.find("waited for SIGINT"), std::string::npos) << child.log;
  EXPECT_NE(child.log.find("received SIGTERM again"), std::string::npos) << child.log;
}

TEST(ShutdownSignalTest, AShutdownThatFinishesInTimeDisarmsTheBound) {
  const Child child = RunChild([](auto log) {
    ShutdownSignal signals(milliseconds(200), log);
    kill(getpid(), SIGTERM);
    signals.Wait();
    signals.Disarm();
    std::this_thread::sleep_for(milliseconds(600));  // past the bound
  });
  EXPECT_EQ(child.exit_status, 7) << child.log;  // the body's own end
  EXPECT_EQ(child.log, "");
}

}  // namespace
}  // namespace dysa::service
