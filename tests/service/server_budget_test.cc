// StreamFrames budgets over real gRPC (docs/server.md, "Budgets and detail"): a budgeted stream
// gets a subset by rank that decodes with its ids, GetStatus reports each stream, a request
// without budgets streams as before, and bad budgets are refused naming the field while the
// server keeps running.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <optional>
#include <string>

#include "dysa/codec/detail_subset.h"
#include "dysa/codec/frame_codec.h"
#include "dysa/service/server.h"
#include "dysa/service/simulation_host.h"
#include "dysa/v1/simulation.grpc.pb.h"
#include "support/in_process_server.h"

namespace dysa::service {
namespace {

using v1::Simulation;

using Fixture = testing::InProcessServer;
using testing::Context;
using testing::FirstFrame;

v1::Status GetStatus(Simulation::Stub& stub) {
  v1::Status status;
  EXPECT_TRUE(stub.GetStatus(Context().get(), {}, &status).ok());
  return status;
}

TEST(ServerBudgetTest, AParticleBudgetGetsAnEvenSubsetThatNamesItsParticles) {
  Fixture f;
  v1::StreamFramesRequest request;
  request.set_fps_target(30);
  request.set_particle_budget(200);
  auto context = Context();
  auto reader = f.stub().StreamFrames(context.get(), request);
  const std::optional<codec::Frame> frame = FirstFrame(*reader);
  ASSERT_TRUE(frame);
  EXPECT_NE(frame->detail_threshold, 0u);
  EXPECT_LE(frame->count, 240u);  // the budget's fraction of 1000, up to sampling spread
  EXPECT_GT(frame->count, 100u);
  ASSERT_EQ(frame->ids.size(), frame->count);
  for (uint32_t id : frame->ids) {
    EXPECT_LT(id, 1000u);
    EXPECT_LT(codec::DetailRank(id), frame->detail_threshold);
  }
  const v1::Status status = GetStatus(f.stub());
  ASSERT_EQ(status.streams_size(), 1);
  const v1::StreamStatus& s = status.streams(0);
  EXPECT_EQ(s.particle_budget(), 200u);
  EXPECT_EQ(s.fps_target(), 30);
  EXPECT_LE(s.detail() * 1000, 200);
  EXPECT_GT(s.detail(), 0.1);
  context->TryCancel();
}

TEST(ServerBudgetTest, ARequestWithoutBudgetsStreamsEveryParticle) {
  Fixture f;
  auto context = Context();
  auto reader = f.stub().StreamFrames(context.get(), {});
  const std::optional<codec::Frame> frame = FirstFrame(*reader);
  ASSERT_TRUE(frame);
  EXPECT_EQ(frame->detail_threshold, 0u);
  EXPECT_EQ(frame->count, 1000u);
  EXPECT_TRUE(frame->ids.empty());
  const v1::Status status = GetStatus(f.stub());
  ASSERT_EQ(status.streams_size(), 1);
  EXPECT_EQ(status.streams(0).detail(), 1.0);
  EXPECT_EQ(status.streams(0).fps_target(), 0);
  context->TryCancel();
}

TEST(ServerBudgetTest, BadBudgetsAreRefusedNamingTheFieldAndTheServerGoesOn) {
  Fixture f;
  auto refused = [&](v1::StreamFramesRequest request, const std::string& field) {
    auto context = Context();
    auto reader = f.stub().StreamFrames(context.get(), request);
    v1::FrameMessage message;
    EXPECT_FALSE(reader->Read(&message));
    const grpc::Status s = reader->Finish();
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << field;
    EXPECT_NE(s.error_message().find(field), std::string::npos) << s.error_message();
  };
  v1::StreamFramesRequest r;
  r.set_fps_target(5000);
  refused(r, "fps_target: allowed range [0, 1000]");
  r.Clear();
  r.set_byte_budget(100000);
  refused(r, "byte_budget: needs fps_target");
  r.Clear();
  r.set_fps_target(30);
  r.set_byte_budget(10);
  refused(r, "byte_budget: allowed range");
  r.Clear();
  r.set_particle_budget(30'000'000);
  refused(r, "particle_budget: allowed range");
  EXPECT_EQ(GetStatus(f.stub()).particles(), 1000u);
}

}  // namespace
}  // namespace dysa::service
