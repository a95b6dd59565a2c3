// The controls waiting for the simulation thread, and everything else that wakes it: a
// subscriber waiting for a frame, and the request to stop.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <optional>

#include "dysa/service/controls.h"

namespace dysa::service {

// A control as the simulation thread takes it: with whom to answer and who waits.
struct QueuedControl {
  Control control;
  std::function<void(ControlResult)> done;
  ControlCaller caller;
  std::chrono::steady_clock::time_point queued;
};

class ControlQueue {
 public:
  using Clock = std::chrono::steady_clock;

  // Queues `job` and wakes the thread. False once Close() was called: `job` is left to the
  // caller to answer.
  bool Push(QueuedControl& job);
  // Takes no more controls and wakes the thread to stop; returns the controls still queued,
  // for the caller to answer.
  std::deque<QueuedControl> Close();
  // A subscriber waits for a frame (even while paused): wakes the thread.
  void RequestFrame();

  struct Wake {
    bool stop = false;                     // Close() was called
    std::optional<QueuedControl> control;  // the oldest control, one per call
    bool frame_requested = false;          // only when no control was taken
  };
  // Waits until a control is queued, a frame is requested or the queue is closed, or until
  // `until` (time_point::max(): no limit; a past time: does not wait).
  Wake Next(Clock::time_point until);

  // A control is queued, or the queue closed: a running frame or Step yields to it between two
  // steps. Read by the solver's step loop without a lock.
  bool attention() const { return attention_.load(std::memory_order_relaxed); }

  // The simulation thread has returned: StopWithin's wait ends.
  void MarkFinished();
  // Waits until MarkFinished() or `deadline`; true when finished.
  bool WaitFinished(Clock::time_point deadline);

 private:
  std::mutex mu_;
  std::condition_variable wake_;
  std::deque<QueuedControl> queue_;
  bool closed_ = false;
  bool frame_requested_ = false;
  bool finished_ = false;
  std::condition_variable finished_cv_;
  std::atomic<bool> attention_{false};  // written under mu_
};

}  // namespace dysa::service
