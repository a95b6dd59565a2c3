// SIGINT and SIGTERM for a server process, and a bound on the shutdown they start.
//
// A container gets 10 s after SIGTERM by default before it is killed, and a solver step cannot be
// interrupted: one step of a pathological scene can take minutes. So once a signal has arrived
// the process ends within `bound` whatever runs: the orderly shutdown has until deadline() and
// calls Disarm() when done; if it has not by then, or on a second signal, the process exits at
// once (std::_Exit, status 0, after logging why), without waiting for the threads still working.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

namespace dysa::service {

class ShutdownSignal {
 public:
  // Blocks SIGINT and SIGTERM in the calling thread, and so in every thread it starts later (they
  // inherit its mask): construct it before any other thread starts. `log` gets one line per
  // event; it is called on the signal thread.
  ShutdownSignal(std::chrono::milliseconds bound, std::function<void(const std::string&)> log);
  ~ShutdownSignal();  // Disarm()
  ShutdownSignal(const ShutdownSignal&) = delete;
  ShutdownSignal& operator=(const ShutdownSignal&) = delete;

  // Blocks until SIGINT or SIGTERM has arrived (returns at once if one came earlier); returns its
  // name, "SIGINT" or "SIGTERM".
  std::string Wait();
  // When the process ends at the latest: the first signal's arrival plus the bound.
  std::chrono::steady_clock::time_point deadline() const;
  // The orderly shutdown is done (or the process ends by itself): nothing exits it any more.
  // Joins the signal thread; idempotent.
  void Disarm();

 private:
  // Blocks SIGINT and SIGTERM in the calling thread; returns true.
  static bool BlockSignals();
  void Watch();

  const bool blocked_ = BlockSignals();  // first: before thread_ starts
  const std::chrono::milliseconds bound_;
  const std::function<void(const std::string&)> log_;
  mutable std::mutex mu_;
  std::condition_variable received_cv_;
  std::string received_;  // the first signal's name; empty until one arrives
  std::chrono::steady_clock::time_point deadline_ = std::chrono::steady_clock::time_point::max();
  std::atomic<bool> disarmed_{false};
  std::thread thread_;  // last: starts once the members above exist
};

}  // namespace dysa::service
