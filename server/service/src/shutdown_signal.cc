#include "dysa/service/shutdown_signal.h"

#include <pthread.h>
#include <signal.h>

#include <algorithm>
#include <cstdlib>
#include <ctime>

namespace dysa::service {

namespace {

using Clock = std::chrono::steady_clock;

sigset_t ShutdownSignals() {
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  return signals;
}

const char* SignalName(int signal) { return signal == SIGINT ? "SIGINT" : "SIGTERM"; }

// The signal thread polls: sigtimedwait cannot be woken by Disarm, and a slice bounds how long
// Disarm waits for it (and how late past the deadline the process ends).
constexpr auto kSlice = std::chrono::milliseconds(20);

}  // namespace

ShutdownSignal::ShutdownSignal(std::chrono::milliseconds bound,
                               std::function<void(const std::string&)> log)
    : bound_(bound), log_(std::move(log)), thread_([this] { Watch(); }) {}

ShutdownSignal::~ShutdownSignal() { Disarm(); }

bool ShutdownSignal::BlockSignals() {
  const sigset_t signals = ShutdownSignals();
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  return true;
}

std::string ShutdownSignal::Wait() {
  std::unique_lock lock(mu_);
  received_cv_.wait(lock, [&] { return !received_.empty(); });
  return received_;
}

Clock::time_point ShutdownSignal::deadline() const {
  std::lock_guard lock(mu_);
  return deadline_;
}

void ShutdownSignal::Disarm() {
  disarmed_ = true;
  if (thread_.joinable() && thread_.get_id() != std::this_thread::get_id()) thread_.join();
}

void ShutdownSignal::Watch() {
  const sigset_t signals = ShutdownSignals();
  while (!disarmed_) {
    auto wait = Clock::duration(kSlice);
    bool armed = false;
    {
      std::lock_guard lock(mu_);
      armed = !received_.empty();
      if (armed) wait = std::min(wait, std::max(deadline_ - Clock::now(), Clock::duration(0)));
    }
    const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(wait).count();
    const timespec timeout{time_t(ns / 1'000'000'000), long(ns % 1'000'000'000)};
    const int signal = sigtimedwait(&signals, nullptr, &timeout);
    if (disarmed_) return;
    if (signal > 0 && armed) {
      log_(std::string("received ") + SignalName(signal) + " again: exiting now");
      std::_Exit(0);
    }
    if (signal > 0) {
      std::lock_guard lock(mu_);
      received_ = SignalName(signal);
      deadline_ = Clock::now() + bound_;
      received_cv_.notify_all();
      continue;
    }
    if (armed && Clock::now() >= deadline()) {
      log_("the shutdown did not finish within " + std::to_string(bound_.count()) +
           " ms of the signal: exiting without waiting for it");
      std::_Exit(0);
    }
  }
}

}  // namespace dysa::service
