// Test helpers shared by the suites that write files.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "support/die_with_parent.h"

namespace dysa::testing {

// A fresh directory under the test temp dir, named after the running test, removed at the end.
class TempDir {
 public:
  explicit TempDir(const std::string& prefix) {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = std::filesystem::path(::testing::TempDir()) /
            (prefix + "_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() { std::filesystem::remove_all(path_); }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// The whole file; a failed expectation if it cannot be opened.
inline std::string ReadFile(const std::filesystem::path& path) {
  std::ifstream file(path, std::ios::binary);
  EXPECT_TRUE(file) << path;
  std::stringstream text;
  text << file.rdbuf();
  return text.str();
}

// The exit status and output of a command line run by RunCaptured.
struct CommandResult {
  int exit_code = -1;  // -1 when the shell could not run it or it died of a signal
  std::string out;
  std::string err;
};

// Runs `command` through the shell with no input, capturing stdout and stderr into files under
// `dir` (so a large output never blocks on a pipe).
inline CommandResult RunCaptured(const std::filesystem::path& dir, const std::string& command) {
  const std::filesystem::path out = dir / "stdout.txt";
  const std::filesystem::path err = dir / "stderr.txt";
  const std::string line = command + " >'" + out.string() + "' 2>'" + err.string() + "' </dev/null";
  // std::system, but the shell dies with the test (a command left running would outlive it).
  int status = -1;
  if (const pid_t pid = fork(); pid == 0) {
    DieWithParent();
    execl("/bin/sh", "sh", "-c", line.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  } else if (pid > 0) {
    while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
  }
  CommandResult result;
  result.exit_code = (status != -1 && WIFEXITED(status)) ? WEXITSTATUS(status) : -1;
  result.out = ReadFile(out);
  result.err = ReadFile(err);
  return result;
}

}  // namespace dysa::testing
