// Scenes above a frame's particle limit (issue 32, item 4), with the limit lowered to 500 for a
// scene of 1000 particles: a full-detail stream is refused naming the limit and what to ask for,
// a budgeted stream gets frames within the limit (its budget or not), a stride that fits is
// served, and the server goes on. And the snapshot behind a budgeted stream copies only the
// particles its detail sends.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <string>

#include "dysa/codec/detail_subset.h"
#include "dysa/codec/frame_codec.h"
#include "dysa/service/frame_publisher.h"
#include "dysa/service/server.h"
#include "dysa/service/simulation_host.h"
#include "dysa/v1/simulation.grpc.pb.h"
#include "support/in_process_server.h"

namespace dysa::service {
namespace {

using v1::Simulation;

constexpr uint64_t kLimit = 500;

// The test server with its frame limit lowered to kLimit.
class Fixture : public testing::InProcessServer {
 public:
  Fixture() : InProcessServer(LimitedHost()) {}

 private:
  static HostOptions LimitedHost() {
    HostOptions options = testing::PausedHostOptions();
    options.max_frame_particles = kLimit;
    return options;
  }
};

using testing::Context;
using testing::FirstFrame;

TEST(FrameLimitTest, AFullDetailStreamOverTheLimitIsRefusedNamingIt) {
  Fixture f;
  for (int attempt = 0; attempt < 2; ++attempt) {  // before and after a frame was published
    auto context = Context();
    auto reader = f.stub().StreamFrames(context.get(), {});
    v1::FrameMessage message;
    EXPECT_FALSE(reader->Read(&message));
    const grpc::Status s = reader->Finish();
    EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << s.error_message();
    EXPECT_NE(s.error_message().find("1000 particles; a frame holds at most 500"),
              std::string::npos)
        << s.error_message();
    EXPECT_NE(s.error_message().find("budget"), std::string::npos) << s.error_message();
    // Publish one budgeted frame, so that the second attempt meets a known particle count.
    v1::StreamFramesRequest budgeted;
    budgeted.set_particle_budget(100);
    auto other = Context();
    auto budget_reader = f.stub().StreamFrames(other.get(), budgeted);
    ASSERT_TRUE(FirstFrame(*budget_reader));
    other->TryCancel();
  }
  v1::Status status;
  ASSERT_TRUE(f.stub().GetStatus(Context().get(), {}, &status).ok());
  EXPECT_EQ(status.particles(), 1000u) << "the server goes on";
}

TEST(FrameLimitTest, BudgetedStreamsStayWithinTheLimit) {
  Fixture f;
  auto check = [&](v1::StreamFramesRequest request, const char* what) {
    auto context = Context();
    auto reader = f.stub().StreamFrames(context.get(), request);
    const std::optional<codec::Frame> frame = FirstFrame(*reader);
    ASSERT_TRUE(frame) << what;
    EXPECT_NE(frame->detail_threshold, 0u) << what;
    EXPECT_LE(frame->count, kLimit) << what;
    EXPECT_GT(frame->count, 150u) << what << ": the largest detail under the limit, not less";
    ASSERT_EQ(frame->ids.size(), frame->count);
    for (uint32_t id : frame->ids) EXPECT_LT(codec::DetailRank(id), frame->detail_threshold);
    context->TryCancel();
  };
  v1::StreamFramesRequest request;
  request.set_fps_target(30);
  check(request, "a frame-rate target alone");
  request.Clear();
  request.set_particle_budget(900);
  check(request, "a particle budget above the limit");
}

TEST(FrameLimitTest, AStrideThatFitsIsServed) {
  Fixture f;
  v1::StreamFramesRequest request;
  request.set_stride(2);
  auto context = Context();
  auto reader = f.stub().StreamFrames(context.get(), request);
  const std::optional<codec::Frame> frame = FirstFrame(*reader);
  ASSERT_TRUE(frame);
  EXPECT_EQ(frame->count, 500u);
  context->TryCancel();
}

TEST(FrameLimitTest, TheSnapshotCopiesOnlyTheParticlesItsDetailSends) {
  dysa::Simulation sim(testing::SmallSeedScene());
  sim.StepFrame();
  const size_t n = sim.particle_count();
  std::vector<float> positions(3 * n), velocities(3 * n);
  sim.ReadParticlesById({positions, velocities, {}});
  const uint32_t threshold = codec::DetailThreshold(0.2);
  FrameSnapshot s;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  s.positions.assign(3 * n, nan);
  s.velocities.assign(3 * n, nan);
  GatherSnapshot(sim, codec::kPositions | codec::kSpeed, threshold, s);
  EXPECT_EQ(s.threshold, threshold);
  size_t kept = 0;
  for (uint32_t id = 0; id < n; ++id) {
    const bool keeps = codec::DetailRank(id) < threshold;
    kept += keeps;
    for (int a = 0; a < 3; ++a) {
      if (keeps) {
        EXPECT_EQ(s.positions[3 * id + a], positions[3 * id + a]) << id;
        EXPECT_EQ(s.velocities[3 * id + a], velocities[3 * id + a]) << id;
      } else {
        EXPECT_TRUE(std::isnan(s.positions[3 * id + a])) << id << " was copied";
        EXPECT_TRUE(std::isnan(s.velocities[3 * id + a])) << id << " was copied";
      }
    }
  }
  EXPECT_GT(kept, 100u);
  EXPECT_LT(kept, 300u);
  // Without a threshold every particle is copied, as before.
  GatherSnapshot(sim, codec::kPositions | codec::kSpeed, 0, s);
  EXPECT_EQ(s.threshold, 0u);
  EXPECT_EQ(s.positions, positions);
}

}  // namespace
}  // namespace dysa::service
