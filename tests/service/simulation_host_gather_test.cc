// Tests of what SimulationHost reads (gathers) for its subscribers while it runs: only the frames
// some stream will take. The controls and stepping are simulation_host_test.cc's.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <thread>

#include "dysa/service/simulation_host.h"
#include "service/simulation_host_scenes.h"

namespace dysa::service {
namespace {

// A simulation that runs faster than its only stream's frame-rate cap reads (gathers) only the
// frames the stream takes, not every frame it simulates.
TEST(SimulationHostGatherTest, AFrameTheOnlyStreamsCapSkipsIsNotRead) {
  HostOptions o = Paused();
  o.start_paused = false;
  SimulationHost host(SmallScene(10), o);  // 1,000 particles
  host.Start();
  struct Listener : FrameListener {
    void OnFrameReady() override {}
    void OnHubClosed() override {}
  } listener;
  SubscriptionOptions options;
  options.max_fps = 5;
  auto sub = host.hub().Subscribe(options, &listener);
  // A reader that keeps up (a stream whose frame waits untaken is not read for either).
  std::atomic<bool> stop{false};
  std::thread reader([&] {
    while (!stop) {
      sub->Take(nullptr);
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  });
  const uint64_t first = host.Status().frame;
  std::this_thread::sleep_for(std::chrono::seconds(2));
  const HostStatus status = host.Status();
  stop = true;
  reader.join();
  host.hub().Unsubscribe(sub);
  const uint64_t frames = status.frame - first;
  uint64_t gathers = 0;
  for (const PassStatus& p : status.passes) {
    if (p.name == "gather_frames") gathers = p.calls;
  }
  // 5 frames a second for 2 s (and the first): about 11 reads, of the frames simulated meanwhile
  // (hundreds for 1,000 seed particles; only a machine too slow to run 20 frames in 2 s skips the
  // comparison's point).
  ASSERT_GE(frames, 20u) << "the simulation ran too slowly to compare";
  EXPECT_GE(gathers, 5u);
  EXPECT_LE(gathers, 14u) << frames << " frames simulated";
  // Each frame read is sent (the latest may still be encoding on the publishing thread).
  EXPECT_LE(status.frames_encoded, gathers);
  EXPECT_GE(status.frames_encoded + 1, gathers);
}

// A stream whose client is behind (its frame waits, not taken: a write that does not complete)
// costs the simulation no read and no encoding until it takes that frame.
TEST(SimulationHostGatherTest, AStreamWhoseFrameWaitsUntakenIsNotRead) {
  HostOptions o = Paused();
  o.start_paused = false;
  SimulationHost host(SmallScene(10), o);
  host.Start();
  struct Listener : FrameListener {
    void OnFrameReady() override {}
    void OnHubClosed() override {}
  } listener;
  auto sub = host.hub().Subscribe(SubscriptionOptions{}, &listener);
  auto gathers = [&](const HostStatus& status) {
    for (const PassStatus& p : status.passes) {
      if (p.name == "gather_frames") return p.calls;
    }
    return uint64_t(0);
  };
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  const HostStatus before = host.Status();
  std::this_thread::sleep_for(std::chrono::seconds(1));
  const HostStatus behind = host.Status();
  ASSERT_GE(behind.frame, before.frame + 10) << "the simulation ran too slowly to compare";
  EXPECT_EQ(gathers(behind), gathers(before)) << behind.frame - before.frame << " frames";
  EXPECT_EQ(behind.frames_encoded, before.frames_encoded);
  // It takes the waiting frame: the next frames are read and sent again, deltas after it.
  const auto waiting = sub->Take(nullptr);
  ASSERT_TRUE(waiting);
  std::shared_ptr<const EncodedFrame> next;
  uint32_t skipped = 1;
  for (int i = 0; i < 200 && !next; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    next = sub->Take(&skipped);
  }
  ASSERT_TRUE(next);
  EXPECT_GT(next->frame, waiting->frame);
  // The frames left out are reported missed (the reader's FrameMessage.frames_skipped), and
  // the frame decodes after the waiting one: no gap in the stream's encoded sequence.
  EXPECT_GE(skipped, 10u);
  EXPECT_LE(skipped, next->frame - waiting->frame - 1);
  EXPECT_GT(gathers(host.Status()), gathers(behind));
  host.hub().Unsubscribe(sub);
}

}  // namespace
}  // namespace dysa::service
