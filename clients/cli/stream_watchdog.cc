#include "stream_watchdog.h"

#include <algorithm>
#include <utility>

namespace dysa::remote {

StreamWatchdog::StreamWatchdog(FrameStream& stream, const std::atomic<bool>* interrupted,
                               double seconds, Clock::duration period, std::function<void()> tick)
    : stream_(stream),
      interrupted_(interrupted),
      seconds_(seconds),
      period_(period),
      tick_(std::move(tick)),
      thread_([this] { Run(); }) {}

void StreamWatchdog::Stop() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void StreamWatchdog::Run() {
  const Clock::time_point start = Clock::now();
  const Clock::time_point end =
      start + std::chrono::duration_cast<Clock::duration>(
                  std::chrono::duration<double>(seconds_ > 0 ? seconds_ : 0));
  Clock::time_point next_tick = start + period_;
  std::unique_lock lock(mutex_);
  while (!stop_) {
    wake_.wait_for(lock, std::chrono::milliseconds(50));
    if (stop_) break;
    const Clock::time_point now = Clock::now();
    if (interrupted() || (seconds_ > 0 && now >= end)) {
      ended_ = true;
      stream_.Cancel();
      break;
    }
    if (tick_ && now >= next_tick) {
      lock.unlock();
      tick_();
      lock.lock();
      next_tick = std::max(next_tick + period_, now);
    }
  }
}

}  // namespace dysa::remote
