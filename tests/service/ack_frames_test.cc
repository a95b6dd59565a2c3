// AckFrames over real gRPC (docs/server.md, "Budgets and detail", the delivery signal): a report
// for a live stream is taken and counts in GetStatus, a token is one stream's, and bad or stale
// tokens are refused naming the field while the server goes on.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <string>
#include <thread>

#include "dysa/service/server.h"
#include "dysa/service/simulation_host.h"
#include "dysa/v1/simulation.grpc.pb.h"
#include "support/in_process_server.h"

namespace dysa::service {
namespace {

using v1::Simulation;

using Fixture = testing::InProcessServer;
using testing::Context;

grpc::Status Ack(Simulation::Stub& stub, uint64_t token, uint64_t frames) {
  v1::AckFramesRequest request;
  request.set_ack_token(token);
  request.set_frames(frames);
  request.set_rtt_us(500);
  v1::AckFramesReply reply;
  return stub.AckFrames(Context().get(), request, &reply);
}

TEST(AckFramesTest, AReportForALiveStreamCountsAndATokenIsOneStreams) {
  Fixture f;
  constexpr uint64_t kToken = 0x5eed5eed12345678ull;
  v1::StreamFramesRequest request;
  request.set_fps_target(30);
  request.set_ack_token(kToken);
  auto context = Context();
  auto reader = f.stub().StreamFrames(context.get(), request);
  v1::FrameMessage message;
  do {
    ASSERT_TRUE(reader->Read(&message));
  } while (!message.last_of_frame());
  // Before any report the stream has delivered nothing: it waits for the client's word.
  v1::Status status;
  ASSERT_TRUE(f.stub().GetStatus(Context().get(), {}, &status).ok());
  ASSERT_EQ(status.streams_size(), 1);
  EXPECT_EQ(status.streams(0).frames_per_second(), 0);
  EXPECT_EQ(status.streams(0).age_s(), 0);

  ASSERT_TRUE(Ack(f.stub(), kToken, 1).ok());
  ASSERT_TRUE(f.stub().GetStatus(Context().get(), {}, &status).ok());
  ASSERT_EQ(status.streams_size(), 1);
  EXPECT_GT(status.streams(0).frames_per_second(), 0) << "the reported frame counts";
  EXPECT_GT(status.streams(0).bytes_per_second(), 0);
  EXPECT_GT(status.streams(0).age_s(), 0);
  EXPECT_EQ(status.streams(0).particles(), 1000u);

  // A second stream may not take the same token.
  auto second_context = Context();
  auto second = f.stub().StreamFrames(second_context.get(), request);
  EXPECT_FALSE(second->Read(&message));
  const grpc::Status refused = second->Finish();
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(refused.error_message().find("ack_token"), std::string::npos)
      << refused.error_message();

  // Once the stream has ended, its token is unknown.
  context->TryCancel();
  grpc::Status late = Ack(f.stub(), kToken, 2);
  for (int i = 0; i < 100 && late.ok(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    late = Ack(f.stub(), kToken, 2);
  }
  EXPECT_EQ(late.error_code(), grpc::StatusCode::NOT_FOUND) << late.error_message();
}

TEST(AckFramesTest, BadTokensAreRefusedNamingTheFieldAndTheServerGoesOn) {
  Fixture f;
  const grpc::Status zero = Ack(f.stub(), 0, 1);
  EXPECT_EQ(zero.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(zero.error_message().find("ack_token: allowed range"), std::string::npos)
      << zero.error_message();
  const grpc::Status unknown = Ack(f.stub(), 42, 1);
  EXPECT_EQ(unknown.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_NE(unknown.error_message().find("ack_token"), std::string::npos)
      << unknown.error_message();
  v1::Status status;
  EXPECT_TRUE(f.stub().GetStatus(Context().get(), {}, &status).ok());
  EXPECT_EQ(status.particles(), 1000u);
}

}  // namespace
}  // namespace dysa::service
