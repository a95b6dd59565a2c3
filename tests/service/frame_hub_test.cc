// Tests of dysa/service/frame_hub.h: one encoding per stream configuration, latest-wins
// delivery, keyframes for late joiners and after gaps (one subscriber's gap costs only it a
// keyframe), bounded memory for a stalled subscriber,
// limits, and that what a subscriber takes decodes to the published frame.
#include "dysa/service/frame_hub.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <memory>
#include <thread>
#include <vector>

namespace dysa::service {
namespace {

class CountingListener : public FrameListener {
 public:
  void OnFrameReady() override { ++ready; }
  void OnHubClosed() override { ++closed; }
  std::atomic<int> ready{0};
  std::atomic<int> closed{0};
};

// A block of n particles drifting along x, frame by frame.
FrameSnapshot Snapshot(uint64_t frame, size_t n = 1000) {
  FrameSnapshot s;
  s.frame = frame;
  s.step = 3 * frame;
  s.time = frame / 60.0;
  s.domain_min = {-1, -1, -1};
  s.domain_max = {1, 1, 1};
  for (size_t i = 0; i < n; ++i) {
    const float x = -0.5f + 0.001f * float(i % 100) + 0.002f * float(frame);
    s.positions.insert(s.positions.end(), {x, 0.001f * float(i / 100), 0.1f});
    s.velocities.insert(s.velocities.end(), {0.12f, 0.0f, 0.0f});
    s.densities.push_back(1000.0f);
  }
  return s;
}

SubscriptionOptions Options(uint32_t fields = codec::kPositions | codec::kSpeed) {
  SubscriptionOptions o;
  o.stream.fields = fields;
  return o;
}

TEST(FrameHubTest, NothingIsEncodedWithoutSubscribers) {
  FrameHub hub(8);
  EXPECT_EQ(hub.NeededFields(), 0u);
  hub.Publish(Snapshot(0), false, false);
  EXPECT_EQ(hub.frames_encoded(), 0u);
}

TEST(FrameHubTest, SubscribersWithEqualOptionsShareOneEncoding) {
  FrameHub hub(8);
  CountingListener la, lb, lc;
  auto a = hub.Subscribe(Options(), &la);
  auto b = hub.Subscribe(Options(), &lb);
  auto c = hub.Subscribe(Options(codec::kPositions | codec::kDensity), &lc);
  EXPECT_EQ(hub.NeededFields(), codec::kPositions | codec::kSpeed | codec::kDensity);
  hub.Publish(Snapshot(0), false, false);
  EXPECT_EQ(hub.frames_encoded(), 2u);  // two configurations, three subscribers
  EXPECT_EQ(la.ready, 1);
  EXPECT_EQ(lc.ready, 1);
  const auto fa = a->Take(nullptr);
  const auto fb = b->Take(nullptr);
  const auto fc = c->Take(nullptr);
  ASSERT_TRUE(fa && fb && fc);
  EXPECT_EQ(fa, fb);  // the same encoded bytes
  EXPECT_NE(fa, fc);
  EXPECT_TRUE(fa->keyframe);
  hub.Unsubscribe(a);
  hub.Unsubscribe(b);
  EXPECT_EQ(hub.NeededFields(), codec::kPositions | codec::kDensity);
  hub.Unsubscribe(c);
  EXPECT_EQ(hub.subscribers(), 0u);
}

TEST(FrameHubTest, TakenFramesDecodeToThePublishedPositions) {
  FrameHub hub(8);
  CountingListener l;
  auto sub = hub.Subscribe(Options(), &l);
  codec::FrameDecoder decoder;
  for (uint64_t f = 0; f < 5; ++f) {
    const FrameSnapshot s = Snapshot(f);
    hub.Publish(s, false, false);
    const auto frame = sub->Take(nullptr);
    ASSERT_TRUE(frame);
    EXPECT_EQ(frame->keyframe, f == 0);
    const std::optional<codec::Frame> decoded = decoder.AddChunks(frame->chunks);
    ASSERT_TRUE(decoded);
    ASSERT_EQ(decoded->count, 1000u);
    EXPECT_EQ(decoded->step, s.step);
    for (size_t k = 0; k < s.positions.size(); ++k) {
      ASSERT_LE(std::abs(decoded->positions[k] - s.positions[k]),
                decoded->position_error[k % 3] * 1.0001);
    }
  }
  hub.Unsubscribe(sub);
}

TEST(FrameHubTest, ALateJoinerAsksForAFrameAndStartsFromAKeyframe) {
  FrameHub hub(8);
  int frames_needed = 0;
  hub.set_frame_needed([&] { ++frames_needed; });
  CountingListener la, lb;
  auto a = hub.Subscribe(Options(), &la);
  EXPECT_EQ(frames_needed, 1);
  for (uint64_t f = 0; f < 3; ++f) {
    hub.Publish(Snapshot(f), false, false);
    ASSERT_TRUE(a->Take(nullptr));
  }
  auto b = hub.Subscribe(Options(), &lb);
  EXPECT_EQ(frames_needed, 2);  // the server republishes even when paused
  hub.Publish(Snapshot(3), false, false);
  const auto fa = a->Take(nullptr);
  const auto fb = b->Take(nullptr);
  ASSERT_TRUE(fa && fb);
  EXPECT_TRUE(fb->keyframe);
  EXPECT_EQ(fa, fb);  // still one encoding for both
  hub.Unsubscribe(a);
  hub.Unsubscribe(b);
}

// A subscriber behind (a frame waiting that it has not taken) keeps that frame: the frames
// meanwhile are neither read nor encoded for its group, and the next one is a delta after it.
TEST(FrameHubTest, ASubscriberBehindKeepsItsWaitingFrameAndTheNextIsADeltaAfterIt) {
  FrameHub hub(8);
  CountingListener l;
  auto sub = hub.Subscribe(Options(), &l);
  hub.Publish(Snapshot(0), false, false);
  ASSERT_TRUE(sub->Take(nullptr));
  hub.Publish(Snapshot(1), false, false);  // waits: the subscriber is still sending frame 0
  // Frame 2: nothing to read for it (asked twice, as a simulation thread may), nor to encode.
  const auto now = std::chrono::steady_clock::now();
  EXPECT_EQ(hub.GatherNeeds(/*any_time=*/false, now, 2).fields, 0u);
  EXPECT_EQ(hub.GatherNeeds(/*any_time=*/false, now, 2).fields, 0u);
  for (uint64_t f = 2; f <= 3; ++f) hub.Publish(Snapshot(f), false, false);
  EXPECT_EQ(hub.frames_encoded(), 2u);
  uint32_t skipped = 9;
  auto frame = sub->Take(&skipped);
  ASSERT_TRUE(frame);
  EXPECT_EQ(frame->frame, 1u);
  EXPECT_FALSE(frame->keyframe);
  EXPECT_EQ(skipped, 0u);
  EXPECT_NE(hub.GatherNeeds(false, now, 4).fields, 0u) << "taken: the next frame is read again";
  hub.Publish(Snapshot(4), false, false);
  frame = sub->Take(&skipped);
  ASSERT_TRUE(frame);
  EXPECT_EQ(frame->frame, 4u);
  EXPECT_FALSE(frame->keyframe) << "a delta after frame 1, not a keyframe";
  EXPECT_EQ(skipped, 2u) << "frames 2 and 3, left out, each counted once";
  hub.Unsubscribe(sub);
}

// A forced frame (a pause, a step) replaces the waiting one: the subscriber then lacks the frame
// before it, and gets the newest only after a keyframe, which it asks for.
TEST(FrameHubTest, ASubscriberThatMissedFramesGetsTheNewestOnlyAfterAKeyframe) {
  FrameHub hub(8);
  int frames_needed = 0;
  hub.set_frame_needed([&] { ++frames_needed; });
  CountingListener l;
  auto sub = hub.Subscribe(Options(), &l);
  hub.Publish(Snapshot(0), false, false);
  ASSERT_TRUE(sub->Take(nullptr));
  for (uint64_t f = 1; f <= 3; ++f) hub.Publish(Snapshot(f), /*force=*/true, false);
  // Frame 3 is a delta on frame 2, which this subscriber never had: it is not handed out.
  const int needed_before = frames_needed;
  EXPECT_FALSE(sub->Take(nullptr));
  EXPECT_EQ(frames_needed, needed_before + 1);
  hub.Publish(Snapshot(4), false, false);
  uint32_t skipped = 0;
  const auto frame = sub->Take(&skipped);
  ASSERT_TRUE(frame);
  EXPECT_TRUE(frame->keyframe);
  EXPECT_EQ(frame->frame, 4u);
  EXPECT_EQ(skipped, 3u);
  hub.Unsubscribe(sub);
}

// Of two subscribers sharing an encoder, the one that fell behind (its waiting frame replaced
// while the other kept up) gets its keyframe from an encoder of its own; the other's stream
// stays on deltas. Both still decode every frame they take.
TEST(FrameHubTest, ASubscriberBehindItsGroupGetsItsKeyframeAloneAndTheOthersKeepTheirDeltas) {
  FrameHub hub(8);
  CountingListener fast_listener, slow_listener;
  auto fast = hub.Subscribe(Options(), &fast_listener);
  auto slow = hub.Subscribe(Options(), &slow_listener);
  codec::FrameDecoder fast_decoder, slow_decoder;
  hub.Publish(Snapshot(0), false, false);
  for (auto [sub, decoder] : {std::pair{fast, &fast_decoder}, std::pair{slow, &slow_decoder}}) {
    const auto frame = sub->Take(nullptr);
    ASSERT_TRUE(frame);
    ASSERT_TRUE(decoder->AddChunks(frame->chunks));
  }
  for (uint64_t f = 1; f <= 3; ++f) {
    hub.Publish(Snapshot(f), false, false);
    const auto frame = fast->Take(nullptr);
    ASSERT_TRUE(frame) << f;
    EXPECT_FALSE(frame->keyframe) << f;
    ASSERT_TRUE(fast_decoder.AddChunks(frame->chunks)) << f;
  }
  // The slow one's frame 1 was replaced by 2, then 3: a delta on a frame it never had.
  EXPECT_FALSE(slow->Take(nullptr));
  const uint64_t encoded = hub.frames_encoded();
  hub.Publish(Snapshot(4), false, false);
  EXPECT_EQ(hub.frames_encoded(), encoded + 2) << "an encoder each now";
  const auto fast_frame = fast->Take(nullptr);
  ASSERT_TRUE(fast_frame);
  EXPECT_FALSE(fast_frame->keyframe) << "the one that kept up keeps its deltas";
  ASSERT_TRUE(fast_decoder.AddChunks(fast_frame->chunks));
  const auto slow_frame = slow->Take(nullptr);
  ASSERT_TRUE(slow_frame);
  EXPECT_TRUE(slow_frame->keyframe);
  EXPECT_EQ(slow_frame->frame, 4u);
  ASSERT_TRUE(slow_decoder.AddChunks(slow_frame->chunks));
  // From here each follows its own encoder's deltas.
  hub.Publish(Snapshot(5), false, false);
  for (auto [sub, decoder] : {std::pair{fast, &fast_decoder}, std::pair{slow, &slow_decoder}}) {
    const auto frame = sub->Take(nullptr);
    ASSERT_TRUE(frame);
    EXPECT_FALSE(frame->keyframe);
    EXPECT_EQ(frame->frame, 5u);
    ASSERT_TRUE(decoder->AddChunks(frame->chunks));
  }
  hub.Unsubscribe(fast);
  hub.Unsubscribe(slow);
}

TEST(FrameHubTest, AStalledSubscriberHoldsOneFrameAndDoesNotHoldBackOthers) {
  FrameHub hub(8);
  CountingListener stalled_listener, reader_listener;
  auto stalled = hub.Subscribe(Options(), &stalled_listener);
  auto reader = hub.Subscribe(Options(), &reader_listener);
  codec::FrameDecoder decoder;
  for (uint64_t f = 0; f < 200; ++f) {
    hub.Publish(Snapshot(f), false, false);
    const auto frame = reader->Take(nullptr);
    ASSERT_TRUE(frame) << f;
    ASSERT_TRUE(decoder.AddChunks(frame->chunks)) << f;
    ASSERT_LE(hub.frames_alive(), 2);  // the stalled one's pending frame, the reader's
  }
  EXPECT_EQ(hub.frames_encoded(), 200u);
  hub.Unsubscribe(stalled);
  hub.Unsubscribe(reader);
  stalled.reset();  // a subscription owns its pending frame
  reader.reset();
  EXPECT_EQ(hub.frames_alive(), 0);
}

TEST(FrameHubTest, AFrameRateCapSkipsFramesUnlessForced) {
  FrameHub hub(8);
  CountingListener l;
  SubscriptionOptions capped = Options();
  capped.max_fps = 1;  // one frame per wall second
  auto sub = hub.Subscribe(capped, &l);
  for (uint64_t f = 0; f < 5; ++f) hub.Publish(Snapshot(f), false, false);
  EXPECT_EQ(hub.frames_encoded(), 1u);
  hub.Publish(Snapshot(5), /*force=*/true, false);  // a step the user asked for
  EXPECT_EQ(hub.frames_encoded(), 2u);
  hub.Unsubscribe(sub);
}

// A simulation faster than a capped stream does not read the frames the cap would skip: between
// two due frames GatherNeeds leaves the stream out, unless the publish is forced; a stream
// without a cap is always in.
TEST(FrameHubTest, AFrameTheCapWouldSkipIsNotGathered) {
  FrameHub hub(8);
  CountingListener l;
  SubscriptionOptions capped = Options();
  capped.max_fps = 1;
  auto sub = hub.Subscribe(capped, &l);
  // Its first frame is due.
  EXPECT_EQ(hub.GatherNeeds(/*any_time=*/false).fields, capped.stream.fields);
  hub.Publish(Snapshot(0), false, false);
  ASSERT_EQ(hub.frames_encoded(), 1u);
  // The next is due in a second: nothing to read now, except for a forced publish.
  EXPECT_EQ(hub.GatherNeeds(false).fields, 0u);
  EXPECT_EQ(hub.GatherNeeds(/*any_time=*/true).fields, capped.stream.fields);
  // An uncapped stream beside it is read for every frame, and only it takes the next one.
  CountingListener l2;
  auto uncapped = hub.Subscribe(Options(codec::kPositions), &l2);
  EXPECT_EQ(hub.GatherNeeds(false).fields, uint32_t(codec::kPositions));
  hub.Publish(Snapshot(1), false, false);
  EXPECT_EQ(hub.frames_encoded(), 2u);
  hub.Unsubscribe(uncapped);
  hub.Unsubscribe(sub);
}

// Frames produced at twice the cap, each a hair early or late (a real producer's jitter), must
// come at the cap: the next frame is due a period after the previous was due, not after it was
// sent (sent-based, every early frame was skipped and the rate fell to 2/3 of the cap or less).
TEST(FrameHubTest, AFrameRateCapHoldsItsRateUnderJitter) {
  FrameHub hub(8);
  CountingListener l;
  SubscriptionOptions capped = Options();
  capped.max_fps = 20;  // 50 ms
  auto sub = hub.Subscribe(capped, &l);
  const auto start = std::chrono::steady_clock::now();
  constexpr int kFrames = 40;  // 1 s at 40 frames/s, 25 ms apart, every other one 2 ms early
  for (int f = 0; f < kFrames; ++f) {
    std::this_thread::sleep_until(start +
                                  std::chrono::microseconds(25'000 * f - 2'000 * (1 - f % 2)));
    hub.Publish(Snapshot(uint64_t(f)), false, false);
    sub->Take(nullptr);  // a reader that keeps up
  }
  // 20 at the cap; fewer where a loaded machine made the producer itself slower than the cap.
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double expected = std::min(double(kFrames), 1 + 20 * seconds);
  EXPECT_GE(double(hub.frames_encoded()), 0.9 * std::min(expected, 20.0)) << seconds << " s";
  EXPECT_LE(double(hub.frames_encoded()), expected + 1) << seconds << " s";
  hub.Unsubscribe(sub);
}

TEST(FrameHubTest, LimitsAndBadOptionsAreRefusedWithTheirReason) {
  FrameHub hub(1);
  CountingListener l;
  SubscriptionOptions bad = Options();
  bad.stream.position_bits = 30;
  try {
    hub.Subscribe(bad, &l);
    FAIL() << "accepted 30 position bits";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("position_bits"), std::string::npos) << e.what();
  }
  bad = Options();
  bad.max_fps = -1;
  EXPECT_THROW(hub.Subscribe(bad, &l), std::invalid_argument);
  auto sub = hub.Subscribe(Options(), &l);
  EXPECT_THROW(hub.Subscribe(Options(), &l), SubscriberLimitError);
  hub.Unsubscribe(sub);
  EXPECT_NO_THROW(hub.Unsubscribe(hub.Subscribe(Options(), &l)));
}

TEST(FrameHubTest, CloseEndsEveryStreamAndRefusesNewOnes) {
  FrameHub hub(8);
  CountingListener la, lb;
  auto a = hub.Subscribe(Options(), &la);
  auto b = hub.Subscribe(Options(codec::kPositions), &lb);
  hub.Close();
  EXPECT_EQ(la.closed, 1);
  EXPECT_EQ(lb.closed, 1);
  EXPECT_THROW(hub.Subscribe(Options(), &la), SubscriberLimitError);
  hub.Unsubscribe(a);
  hub.Unsubscribe(b);
}

TEST(FrameHubTest, PublishingWhileSubscribersComeAndGoIsSafe) {
  FrameHub hub(64);
  std::atomic<bool> stop{false};
  std::thread publisher([&] {
    for (uint64_t f = 0; !stop; ++f) hub.Publish(Snapshot(f, 200), false, f % 7 == 0);
  });
  for (int i = 0; i < 200; ++i) {
    CountingListener l;
    auto sub =
        hub.Subscribe(Options(i % 2 ? codec::kPositions : codec::kPositions | codec::kSpeed), &l);
    sub->Take(nullptr);
    hub.Unsubscribe(sub);  // after this, `l` is never called: it goes out of scope
  }
  stop = true;
  publisher.join();
  EXPECT_EQ(hub.subscribers(), 0u);
  EXPECT_EQ(hub.configurations(), 0u);
  EXPECT_EQ(hub.configuration_bytes(), 0u);
  EXPECT_EQ(hub.frames_alive(), 0);
}

// The 64 stream configurations whose memory stayed after every stream closed: a
// configuration's encoder and frames go with its last subscriber, even while its stream still
// holds the subscription object.
TEST(FrameHubTest, AConfigurationsBuffersGoWithItsLastSubscriber) {
  constexpr size_t kParticles = 5000;
  constexpr uint32_t kConfigurations = 12;
  FrameHub hub(64);
  CountingListener l;
  std::vector<std::shared_ptr<Subscription>> subs;
  for (uint32_t i = 0; i < kConfigurations; ++i) {
    SubscriptionOptions o = Options(codec::kPositions | codec::kVelocity | codec::kDensity);
    o.stream.position_bits = 8 + i;
    subs.push_back(hub.Subscribe(o, &l));
  }
  // A 13th configuration, with two subscribers sharing its encoder.
  auto shared = hub.Subscribe(Options(), &l);
  auto shared_too = hub.Subscribe(Options(), &l);
  for (uint64_t f = 0; f < 3; ++f) hub.Publish(Snapshot(f, kParticles), false, false);
  EXPECT_EQ(hub.configurations(), kConfigurations + 1);
  // Each encoder keeps at least the quantised positions of the frames it predicts from.
  EXPECT_GT(hub.configuration_bytes(), (kConfigurations + 1) * kParticles * 3 * sizeof(uint32_t));
  EXPECT_GT(hub.frames_alive(), 0);

  const size_t one_configuration = hub.configuration_bytes() / (kConfigurations + 1);
  hub.Unsubscribe(shared);  // its configuration still has a subscriber
  EXPECT_EQ(hub.configurations(), kConfigurations + 1);
  for (const auto& sub : subs) hub.Unsubscribe(sub);
  EXPECT_EQ(hub.configurations(), 1u);
  EXPECT_LT(hub.configuration_bytes(), 2 * one_configuration);
  hub.Unsubscribe(shared_too);
  // The subscriptions are still held (as by their streams), yet nothing is.
  EXPECT_EQ(hub.configurations(), 0u);
  EXPECT_EQ(hub.configuration_bytes(), 0u);
  EXPECT_EQ(hub.frames_alive(), 0);
  EXPECT_EQ(subs[0]->Take(nullptr), nullptr);
  hub.Unsubscribe(subs[0]);  // again: nothing happens
}

}  // namespace
}  // namespace dysa::service
