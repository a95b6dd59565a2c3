// Tests of the frame decoder's threads (server/codec/src/task_pool.h): every iteration runs
// once, on several threads; an exception reaches the caller and the pool goes on; and idle
// threads sleep (a client decoding next to a server must not spin on its cores).
#include "task_pool.h"

#include <gtest/gtest.h>
#include <time.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

namespace dysa::codec {
namespace {

TEST(TaskPoolTest, RunsEveryIterationOnceOnSeveralThreads) {
  TaskPool pool(3);
  for (size_t n : {size_t(0), size_t(1), size_t(2), size_t(1000)}) {
    std::vector<std::atomic<int>> runs(n);
    std::mutex mu;
    std::set<std::thread::id> threads;
    pool.Run(n, [&](size_t i) {
      ++runs[i];
      std::this_thread::sleep_for(std::chrono::microseconds(50));
      std::lock_guard lock(mu);
      threads.insert(std::this_thread::get_id());
    });
    for (size_t i = 0; i < n; ++i) ASSERT_EQ(runs[i].load(), 1) << "n " << n << ", i " << i;
    if (n == 1000) {
      EXPECT_GT(threads.size(), 1u);  // 1000 x 50 us: the workers took part
    }
    if (n == 1) {
      EXPECT_EQ(threads.count(std::this_thread::get_id()), 1u);  // the caller alone
    }
  }
}

TEST(TaskPoolTest, AnExceptionReachesTheCallerAndThePoolGoesOn) {
  TaskPool pool(2);
  std::atomic<int> runs = 0;
  EXPECT_THROW(pool.Run(50,
                        [&](size_t i) {
                          ++runs;
                          if (i == 17) throw std::runtime_error("chunk 17");
                        }),
               std::runtime_error);
  EXPECT_EQ(runs.load(), 50);  // the other iterations still ran
  runs = 0;
  pool.Run(10, [&](size_t) { ++runs; });
  EXPECT_EQ(runs.load(), 10);
}

double ProcessCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

// Between loops the workers block: 7 of them idle for 0.3 s take well under a core's 0.3 s (a
// spinning pool would take 7 x 0.3 s).
TEST(TaskPoolTest, IdleWorkersSleep) {
  TaskPool pool(7);
  std::atomic<int> runs = 0;
  pool.Run(64, [&](size_t) { ++runs; });
  const double before = ProcessCpuSeconds();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_LT(ProcessCpuSeconds() - before, 0.05);
  EXPECT_EQ(runs.load(), 64);
}

}  // namespace
}  // namespace dysa::codec
