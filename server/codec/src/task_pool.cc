#include "task_pool.h"

#include <algorithm>
#include <utility>

namespace dysa::codec {

TaskPool::TaskPool(int workers) {
  for (int i = 0; i < workers; ++i) threads_.emplace_back([this] { Work(); });
}

TaskPool::~TaskPool() {
  {
    std::lock_guard lock(mu_);
    stop_ = true;
  }
  wake_.notify_all();
  for (std::thread& t : threads_) t.join();
}

void TaskPool::Run(size_t n, const std::function<void(size_t)>& body) {
  if (n == 0) return;
  if (n == 1) {
    // The caller's alone, unpublished: a worker that starts (or wakes spuriously) while a loop
    // is published would take it (TaskPoolTest saw one under load).
    body(0);
    return;
  }
  {
    std::lock_guard lock(mu_);
    body_ = &body;
    size_ = n;
    next_ = 0;
    finished_ = 0;
    error_ = nullptr;
    ++generation_;
  }
  // Only as many threads as there are iterations besides the caller's: a burst of runnable
  // threads preempts a neighbouring solver's threads at their barriers.
  const size_t helpers = std::min(n - 1, threads_.size());
  for (size_t i = 0; i < helpers; ++i) wake_.notify_one();
  Drain();
  std::unique_lock lock(mu_);
  done_.wait(lock, [&] { return finished_ == size_; });
  body_ = nullptr;
  if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
}

void TaskPool::Drain() {
  std::unique_lock lock(mu_);
  while (body_ && next_ < size_) {
    const size_t i = next_++;
    const std::function<void(size_t)>& body = *body_;
    lock.unlock();
    std::exception_ptr error;
    try {
      body(i);
    } catch (...) {
      error = std::current_exception();
    }
    lock.lock();
    if (error && !error_) error_ = error;
    if (++finished_ == size_) done_.notify_all();
  }
}

void TaskPool::Work() {
  uint64_t seen = 0;
  for (;;) {
    {
      std::unique_lock lock(mu_);
      wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
      if (stop_) return;
      seen = generation_;
    }
    Drain();
  }
}

}  // namespace dysa::codec
