#include "control_queue.h"

#include <utility>

namespace dysa::service {

bool ControlQueue::Push(QueuedControl& job) {
  {
    std::lock_guard lock(mu_);
    if (closed_) return false;
    queue_.push_back(std::move(job));
    attention_ = true;
  }
  wake_.notify_one();
  return true;
}

std::deque<QueuedControl> ControlQueue::Close() {
  std::deque<QueuedControl> left;
  {
    std::lock_guard lock(mu_);
    closed_ = true;
    attention_ = true;
    left.swap(queue_);
  }
  wake_.notify_one();
  return left;
}

void ControlQueue::RequestFrame() {
  {
    std::lock_guard lock(mu_);
    frame_requested_ = true;
  }
  wake_.notify_one();
}

ControlQueue::Wake ControlQueue::Next(Clock::time_point until) {
  std::unique_lock lock(mu_);
  const auto ready = [&] { return closed_ || !queue_.empty() || frame_requested_; };
  if (until == Clock::time_point::max()) {
    wake_.wait(lock, ready);
  } else if (until > Clock::now()) {
    wake_.wait_until(lock, until, ready);
  }
  Wake wake;
  wake.stop = closed_;
  if (wake.stop) return wake;
  // One control at a time: what is still queued interrupts whatever this one starts.
  if (!queue_.empty()) {
    wake.control = std::move(queue_.front());
    queue_.pop_front();
    attention_ = !queue_.empty();
  } else {
    std::swap(wake.frame_requested, frame_requested_);
  }
  return wake;
}

void ControlQueue::MarkFinished() {
  std::lock_guard lock(mu_);
  finished_ = true;
  finished_cv_.notify_all();
}

bool ControlQueue::WaitFinished(Clock::time_point deadline) {
  std::unique_lock lock(mu_);
  return finished_cv_.wait_until(lock, deadline, [&] { return finished_; });
}

}  // namespace dysa::service
