// The thread beside the blocking reads of a StreamFrames call (dysa watch, dysa record).
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>

#include "dysa/client/client.h"

namespace dysa::remote {

// Runs beside the blocking reads of a stream: cancels it on an interruption (Ctrl-C) or once
// `seconds` have passed, and calls `tick` every `period` (to print progress). A thread of its
// own because a blocked Read() cannot look at the clock or a flag.
class StreamWatchdog {
 public:
  using Clock = std::chrono::steady_clock;

  // `seconds` 0: no time limit. `tick` may be empty.
  StreamWatchdog(FrameStream& stream, const std::atomic<bool>* interrupted, double seconds,
                 Clock::duration period, std::function<void()> tick);
  ~StreamWatchdog() { Stop(); }
  StreamWatchdog(const StreamWatchdog&) = delete;
  StreamWatchdog& operator=(const StreamWatchdog&) = delete;

  void Stop();
  // The stream was cancelled by an interruption or the end of `seconds`.
  bool ended() const { return ended_; }
  bool interrupted() const { return interrupted_ != nullptr && interrupted_->load(); }

 private:
  void Run();

  FrameStream& stream_;
  const std::atomic<bool>* interrupted_;
  double seconds_;
  Clock::duration period_;
  std::function<void()> tick_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;
  std::atomic<bool> ended_{false};
  std::thread thread_;  // last: starts once the members above exist
};

}  // namespace dysa::remote
