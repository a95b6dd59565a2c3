// FrameHub with budgets: a subscriber's detail controller chooses the subset it is sent, the
// hub moves it between encoder groups as the detail changes (a keyframe at each move), the
// frames decode with the ids of the subset, and GetStatus's per-stream reports.
#include <gtest/gtest.h>

#include <atomic>
#include <memory>
#include <vector>

#include "dysa/codec/detail_subset.h"
#include "dysa/service/frame_hub.h"

namespace dysa::service {
namespace {

class Listener : public FrameListener {
 public:
  void OnFrameReady() override { ++ready; }
  void OnHubClosed() override {}
  std::atomic<int> ready{0};
};

FrameSnapshot Snapshot(uint64_t frame, size_t n) {
  FrameSnapshot s;
  s.frame = frame;
  s.domain_min = {-1, -1, -1};
  s.domain_max = {1, 1, 1};
  for (size_t i = 0; i < n; ++i) {
    s.positions.insert(s.positions.end(),
                       {-0.9f + 1.8f * float(i % 97) / 97, 0.001f * float(i / 97), 0.01f * frame});
    s.velocities.insert(s.velocities.end(), {0.1f, 0, 0});
  }
  return s;
}

TEST(FrameHubDetailTest, WithoutABudgetFramesHoldEveryParticle) {
  FrameHub hub(4);
  Listener l;
  auto s = hub.Subscribe({}, &l);
  hub.Publish(Snapshot(0, 2000), false, false);
  auto frame = s->Take(nullptr);
  ASSERT_TRUE(frame);
  EXPECT_EQ(frame->particles, 2000u);
  EXPECT_EQ(frame->total_particles, 2000u);
  const auto reports = hub.StreamReports(SteadySeconds());
  ASSERT_EQ(reports.size(), 1u);
  EXPECT_EQ(reports[0].status.fraction, 1.0);
  EXPECT_FALSE(reports[0].budget.active());
}

TEST(FrameHubDetailTest, AParticleBudgetPicksANestedSubsetThatDecodesWithItsIds) {
  FrameHub hub(4);
  Listener l;
  SubscriptionOptions o;
  o.budget = {.fps_target = 30, .particles_per_frame = 500};
  hub.Publish(Snapshot(0, 4000), false, false);  // no one subscribed: nothing encoded
  auto s = hub.Subscribe(o, &l);
  hub.Publish(Snapshot(1, 4000), false, false);
  auto frame = s->Take(nullptr);
  ASSERT_TRUE(frame);
  EXPECT_TRUE(frame->keyframe);
  EXPECT_LE(frame->particles, 500u * 1.15);  // the budget, up to the subset's sampling spread
  EXPECT_GT(frame->particles, 250u);
  codec::FrameDecoder decoder;
  auto decoded = decoder.AddChunks(frame->chunks);
  ASSERT_TRUE(decoded);
  ASSERT_EQ(decoded->ids.size(), frame->particles);
  for (uint32_t id : decoded->ids) EXPECT_LT(codec::DetailRank(id), decoded->detail_threshold);
  // Delta frames follow while the detail holds.
  hub.FrameStarted(s, 1.0, *frame, 0.99);
  hub.BytesDelivered(s, 1.001, frame->bytes, true);
  hub.Publish(Snapshot(2, 4000), false, false);
  auto next = s->Take(nullptr);
  ASSERT_TRUE(next);
  EXPECT_FALSE(next->keyframe);
  EXPECT_TRUE(decoder.AddChunks(next->chunks).has_value());
}

TEST(FrameHubDetailTest, LatenessMovesTheStreamToALowerDetailWithAKeyframe) {
  FrameHub hub(4);
  Listener la, lb;
  SubscriptionOptions o;
  o.budget = {.fps_target = 30};
  auto a = hub.Subscribe(o, &la);
  auto b = hub.Subscribe({}, &lb);  // no budget: unaffected
  hub.Publish(Snapshot(0, 4000), false, false);
  EXPECT_EQ(hub.configurations(), 1u);  // both whole: one encoder
  auto fa = a->Take(nullptr);
  ASSERT_TRUE(fa);
  ASSERT_TRUE(b->Take(nullptr));
  hub.FrameStarted(a, 1.0, *fa, 1.0);
  hub.BytesDelivered(a, 1.001, fa->bytes, true);
  hub.Publish(Snapshot(1, 4000), false, false);
  fa = a->Take(nullptr);
  ASSERT_TRUE(fa);
  ASSERT_TRUE(b->Take(nullptr));
  hub.FrameStarted(a, 1.03, *fa, 1.03);
  hub.FrameLate(a, 1.06);  // the next frame came while this one was still being written
  EXPECT_EQ(hub.configurations(), 2u);
  hub.Publish(Snapshot(2, 4000), false, false);
  auto lower = a->Take(nullptr);
  ASSERT_TRUE(lower);
  EXPECT_TRUE(lower->keyframe);
  EXPECT_LT(lower->particles, 4000u * 0.8);
  EXPECT_GT(lower->particles, 4000u * 0.6);
  auto whole = b->Take(nullptr);
  ASSERT_TRUE(whole);
  EXPECT_EQ(whole->particles, 4000u);
  EXPECT_FALSE(whole->keyframe);
  const auto reports = hub.StreamReports(2.0);
  ASSERT_EQ(reports.size(), 2u);
  EXPECT_NEAR(reports[0].status.fraction, 0.7071, 1e-3);
  EXPECT_EQ(reports[0].budget.fps_target, 30);
  EXPECT_GT(reports[0].status.bytes_per_second, 0);
  hub.Unsubscribe(a);
  EXPECT_EQ(hub.configurations(), 1u);  // the lower detail's encoder went with it
  hub.Unsubscribe(b);
}

TEST(FrameHubDetailTest, BadBudgetsAreRefusedNamingTheField) {
  FrameHub hub(4);
  Listener l;
  SubscriptionOptions o;
  o.budget = {.fps_target = 5000};
  EXPECT_THROW(
      {
        try {
          hub.Subscribe(o, &l);
        } catch (const std::invalid_argument& e) {
          EXPECT_NE(std::string(e.what()).find("fps_target"), std::string::npos);
          throw;
        }
      },
      std::invalid_argument);
  EXPECT_EQ(hub.subscribers(), 0u);
}

}  // namespace
}  // namespace dysa::service
