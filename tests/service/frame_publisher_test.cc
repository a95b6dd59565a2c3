// Tests of dysa/service/frame_publisher.h: frames are published on the publisher's thread, a
// forced frame is published before Offer returns, a frame offered while the previous one is
// still being published replaces the one waiting (the newest is published, flags carried over),
// and without threads every frame is published inline.
#include "dysa/service/frame_publisher.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <thread>

#include "support/wait_for.h"

namespace dysa::service {
namespace {

using dysa::testing::WaitFor;

// Records the thread that offers frames and, while `hold` is set, blocks in OnFrameReady (that
// is, inside FrameHub::Publish on the publishing thread) until released.
class GateListener : public FrameListener {
 public:
  void OnFrameReady() override {
    std::unique_lock lock(mu);
    thread = std::this_thread::get_id();
    ++ready;
    entered.notify_all();
    released.wait(lock, [&] { return !hold; });
  }
  void OnHubClosed() override {}
  // Until the listener has been called `calls` times.
  void WaitForCalls(int calls) {
    std::unique_lock lock(mu);
    entered.wait(lock, [&] { return ready >= calls; });
  }
  void Release() {
    {
      std::lock_guard lock(mu);
      hold = false;
    }
    released.notify_all();
  }
  std::mutex mu;
  std::condition_variable entered, released;
  bool hold = false;
  int ready = 0;
  std::thread::id thread;
};

FrameSnapshot Snapshot(uint64_t frame) {
  FrameSnapshot s;
  s.frame = frame;
  s.domain_min = {-1, -1, -1};
  s.domain_max = {1, 1, 1};
  for (int i = 0; i < 100; ++i) s.positions.insert(s.positions.end(), {0.01f * float(i), 0, 0});
  return s;
}

SubscriptionOptions Positions() {
  SubscriptionOptions o;
  o.stream.fields = codec::kPositions;
  return o;
}

TEST(FramePublisherTest, AForcedFrameIsPublishedOnThePublishersThreadBeforeOfferReturns) {
  FrameHub hub(4);
  GateListener listener;
  auto subscription = hub.Subscribe(Positions(), &listener);
  FramePublisher publisher(hub, 1);
  FrameSnapshot frame = Snapshot(7);
  publisher.Offer(frame, /*force=*/true, /*discontinuity=*/false);
  EXPECT_EQ(hub.frames_encoded(), 1u);
  EXPECT_NE(listener.thread, std::this_thread::get_id());
  const auto taken = subscription->Take(nullptr);
  ASSERT_TRUE(taken);
  EXPECT_EQ(taken->frame, 7u);
  EXPECT_EQ(publisher.timing().calls, 1u);
  hub.Unsubscribe(subscription);
}

// A publisher with one thread, in the middle of publishing frame 1: the subscriber's listener
// holds it inside FrameHub::Publish until released.
class HeldPublishTest : public ::testing::Test {
 protected:
  void SetUp() override {
    listener_.hold = true;
    subscription_ = hub_.Subscribe(Positions(), &listener_);
    FrameSnapshot frame = Snapshot(1);
    publisher_.Offer(frame, false, false);  // returns at once: not forced
    listener_.WaitForCalls(1);
  }
  void TearDown() override { hub_.Unsubscribe(subscription_); }

  FrameHub hub_{4};
  GateListener listener_;
  std::shared_ptr<Subscription> subscription_;
  FramePublisher publisher_{hub_, 1};
};

TEST_F(HeldPublishTest, AFrameOfferedWhilePublishingReplacesTheOneWaiting) {
  // Frames 2, 3, 4 arrive while frame 1 is being published: only the newest waits, and it keeps
  // frame 3's discontinuity.
  for (uint64_t f = 2; f <= 4; ++f) {
    FrameSnapshot frame = Snapshot(f);
    publisher_.Offer(frame, false, /*discontinuity=*/f == 3);
  }
  listener_.Release();
  ASSERT_TRUE(WaitFor([&] { return publisher_.timing().calls == 2; }, 30));
  EXPECT_EQ(hub_.frames_encoded(), 2u);
  const auto taken = subscription_->Take(nullptr);
  ASSERT_TRUE(taken);
  EXPECT_EQ(taken->frame, 4u);
  EXPECT_TRUE(taken->keyframe);  // the discontinuity of frame 3 carried over
}

TEST_F(HeldPublishTest, StopDropsTheWaitingFrameAndReleasesAForcedOffer) {
  std::atomic<bool> returned{false};
  std::thread forced([&] {
    FrameSnapshot frame = Snapshot(2);
    publisher_.Offer(frame, /*force=*/true, false);
    returned = true;
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_FALSE(returned);  // a forced offer waits while frame 1 is still being published
  std::thread stopper([&] { publisher_.Stop(); });
  ASSERT_TRUE(WaitFor([&] { return returned.load(); }, 30));  // Stop released the forced offer
  listener_.Release();
  stopper.join();
  forced.join();
  EXPECT_EQ(hub_.frames_encoded(), 1u);  // frame 2 was never published
}

TEST(FramePublisherTest, WithoutThreadsEveryFrameIsPublishedInlineOnTheCallersThread) {
  FrameHub hub(4);
  GateListener listener;
  auto subscription = hub.Subscribe(Positions(), &listener);
  FramePublisher publisher(hub, 0);
  for (uint64_t f = 1; f <= 3; ++f) {
    FrameSnapshot frame = Snapshot(f);
    publisher.Offer(frame, /*force=*/false, false);
    EXPECT_EQ(hub.frames_encoded(), f);        // published before Offer returned
    EXPECT_TRUE(subscription->Take(nullptr));  // a reader that keeps up
  }
  EXPECT_EQ(listener.thread, std::this_thread::get_id());
  EXPECT_EQ(publisher.timing().calls, 3u);
  hub.Unsubscribe(subscription);
}

}  // namespace
}  // namespace dysa::service
