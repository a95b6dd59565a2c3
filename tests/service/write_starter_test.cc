// Tests of dysa/service/write_starter.h: a scheduled writer is called on the starter's thread,
// never on the scheduling one; a writer scheduled again before its call is called once; Forget
// drops a queued call and waits for one in progress; the destructor drops what is still queued.
#include "dysa/service/write_starter.h"

#include <gtest/gtest.h>

#include <atomic>
#include <condition_variable>
#include <future>
#include <mutex>
#include <thread>

#include "support/wait_for.h"

namespace dysa::service {
namespace {

using dysa::testing::WaitFor;

// Counts its calls and, while `hold` is set, blocks inside StartNextWrite until released.
class GateWriter : public WriteStarter::Writer {
 public:
  void StartNextWrite() override {
    std::unique_lock lock(mu);
    thread = std::this_thread::get_id();
    ++calls;
    entered.notify_all();
    released.wait(lock, [&] { return !hold; });
  }
  void WaitUntilInside(int n) {
    std::unique_lock lock(mu);
    entered.wait(lock, [&] { return calls >= n; });
  }
  void Release() {
    {
      std::lock_guard lock(mu);
      hold = false;
    }
    released.notify_all();
  }
  int Calls() {
    std::lock_guard lock(mu);
    return calls;
  }
  std::mutex mu;
  std::condition_variable entered, released;
  bool hold = false;
  int calls = 0;
  std::thread::id thread;
};

TEST(WriteStarterTest, AScheduledWriterIsCalledOnTheStartersThread) {
  WriteStarter starter;
  GateWriter writer;
  starter.Schedule(&writer);
  writer.WaitUntilInside(1);
  EXPECT_NE(writer.thread, std::this_thread::get_id());
  starter.Forget(&writer);
  EXPECT_EQ(writer.Calls(), 1);
}

TEST(WriteStarterTest, ScheduleDoesNotWaitForACallInProgress) {
  WriteStarter starter;
  GateWriter busy;
  busy.hold = true;
  starter.Schedule(&busy);
  busy.WaitUntilInside(1);
  // The starter is blocked inside busy's call: scheduling returns all the same.
  GateWriter other;
  starter.Schedule(&other);
  starter.Schedule(&busy);
  EXPECT_EQ(other.Calls(), 0);
  busy.Release();
  ASSERT_TRUE(WaitFor([&] { return other.Calls() == 1 && busy.Calls() == 2; }));
  starter.Forget(&busy);
  starter.Forget(&other);
}

TEST(WriteStarterTest, AWriterScheduledTwiceBeforeItsCallIsCalledOnce) {
  WriteStarter starter;
  GateWriter busy, twice, last;
  busy.hold = true;
  starter.Schedule(&busy);
  busy.WaitUntilInside(1);
  starter.Schedule(&twice);
  starter.Schedule(&twice);
  starter.Schedule(&last);  // called after twice: when it has run, twice's queue entry is gone
  busy.Release();
  ASSERT_TRUE(WaitFor([&] { return last.Calls() == 1; }));
  EXPECT_EQ(twice.Calls(), 1);
  for (auto* w : {&busy, &twice, &last}) starter.Forget(w);
}

TEST(WriteStarterTest, ForgetDropsAQueuedCall) {
  WriteStarter starter;
  GateWriter busy, forgotten, last;
  busy.hold = true;
  starter.Schedule(&busy);
  busy.WaitUntilInside(1);
  starter.Schedule(&forgotten);
  starter.Schedule(&last);
  starter.Forget(&forgotten);
  busy.Release();
  ASSERT_TRUE(WaitFor([&] { return last.Calls() == 1; }));
  EXPECT_EQ(forgotten.Calls(), 0);
  starter.Forget(&busy);
  starter.Forget(&last);
}

TEST(WriteStarterTest, ForgetWaitsForTheWritersCallInProgress) {
  WriteStarter starter;
  GateWriter writer;
  writer.hold = true;
  starter.Schedule(&writer);
  writer.WaitUntilInside(1);
  std::atomic<bool> forgotten{false};
  auto forget = std::async(std::launch::async, [&] {
    starter.Forget(&writer);
    forgotten = true;
  });
  // Forget cannot return while the call is in progress; it must once the call returns.
  EXPECT_EQ(forget.wait_for(std::chrono::milliseconds(100)), std::future_status::timeout);
  EXPECT_FALSE(forgotten);
  writer.Release();
  forget.get();
  EXPECT_TRUE(forgotten);
}

TEST(WriteStarterTest, TheDestructorDropsQueuedWriters) {
  GateWriter busy, queued;
  busy.hold = true;
  std::thread release;
  {
    WriteStarter starter;
    starter.Schedule(&busy);
    busy.WaitUntilInside(1);
    starter.Schedule(&queued);
    // Released once the destructor below has asked the thread to stop.
    release = std::thread([&] {
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
      busy.Release();
    });
  }  // joins once busy's call returns; queued is never called
  release.join();
  EXPECT_EQ(busy.Calls(), 1);
  EXPECT_EQ(queued.Calls(), 0);
}

}  // namespace
}  // namespace dysa::service
