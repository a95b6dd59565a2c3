#include "dysa/service/write_starter.h"

#include <pthread.h>
#include <sched.h>

#include <algorithm>

namespace dysa::service {

WriteStarter::WriteStarter() : thread_([this] { Loop(); }) {}

WriteStarter::~WriteStarter() {
  {
    std::lock_guard lock(mu_);
    stop_ = true;
  }
  queued_.notify_one();
  thread_.join();
}

void WriteStarter::Schedule(Writer* writer) {
  {
    std::lock_guard lock(mu_);
    if (stop_ || std::find(queue_.begin(), queue_.end(), writer) != queue_.end()) return;
    queue_.push_back(writer);
  }
  queued_.notify_one();
}

void WriteStarter::Forget(Writer* writer) {
  std::unique_lock lock(mu_);
  std::erase(queue_, writer);
  call_returned_.wait(lock, [&] { return calling_ != writer; });
}

void WriteStarter::Loop() {
  // A batch thread: its wake-up does not preempt the simulation's thread, which has just
  // scheduled it, on a machine whose cores the solver keeps busy. (No privilege is needed; if
  // the call fails the thread keeps the normal policy, which only costs that preemption.)
  sched_param param{};
  pthread_setschedparam(pthread_self(), SCHED_BATCH, &param);
  std::unique_lock lock(mu_);
  while (true) {
    queued_.wait(lock, [&] { return stop_ || !queue_.empty(); });
    if (stop_) return;
    calling_ = queue_.front();
    queue_.pop_front();
    lock.unlock();
    calling_->StartNextWrite();  // calling_ is only written by this thread
    lock.lock();
    calling_ = nullptr;
    call_returned_.notify_all();
  }
}

}  // namespace dysa::service
