// Polling for a condition that another thread or process brings about.
#pragma once

#include <chrono>
#include <functional>
#include <thread>

namespace dysa::testing {

// Polls `done` every 10 ms until it holds (true) or `seconds` pass (false).
inline bool WaitFor(const std::function<bool()>& done, double seconds = 60) {
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (!done()) {
    if (std::chrono::steady_clock::now() > give_up) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

}  // namespace dysa::testing
