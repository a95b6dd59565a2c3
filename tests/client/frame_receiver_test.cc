// Tests of clients/cpp/src/frame_receiver.cc against a real dysa-server: frames arrive decoded
// on the background thread, stream options apply, and the receiver finds a restarted server.
#include "dysa/client/frame_receiver.h"

#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <memory>
#include <thread>

#include "support/server_process.h"
#include "support/temp_dir.h"
#include "support/wait_for.h"

#ifndef DYSA_SERVER_BINARY
#error "tests/CMakeLists.txt defines DYSA_SERVER_BINARY"
#endif

namespace dysa::remote {
namespace {

using dysa::testing::ServerProcess;
using dysa::testing::WaitFor;
using Clock = std::chrono::steady_clock;

// seed_basic: 30^3 particles in the domain [-5, 5] x [-3, 3] x [-5, 5].
constexpr uint32_t kSeedBasicParticles = 27000;

class FrameReceiverTest : public ::testing::Test {
 protected:
  // A started receiver of `server`'s stream with the default options.
  static std::unique_ptr<FrameReceiver> Receive(const ServerProcess& server) {
    ConnectOptions connect;
    connect.address = server.address();
    auto receiver = std::make_unique<FrameReceiver>(connect, StreamOptions{});
    receiver->Start();
    return receiver;
  }

  dysa::testing::TempDir dir{"dysa_receiver"};
};

TEST_F(FrameReceiverTest, DeliversDecodedFramesOfTheRunningScene) {
  ServerProcess server(DYSA_SERVER_BINARY, dir.path(), {"--scene", "seed_basic"});
  ASSERT_TRUE(server.running());
  std::unique_ptr<FrameReceiver> receiver = Receive(server);

  ReceivedFrame frame;
  ASSERT_TRUE(WaitFor([&] { return receiver->TakeLatest(frame); })) << receiver->Stats().error;
  EXPECT_EQ(frame.frame.count, kSeedBasicParticles);
  ASSERT_EQ(frame.frame.positions.size(), 3u * kSeedBasicParticles);
  ASSERT_EQ(frame.frame.speed.size(), kSeedBasicParticles);  // the default fields
  for (uint32_t i = 0; i < frame.frame.count; ++i) {
    EXPECT_LE(std::abs(frame.frame.positions[3 * i + 1]), 3.0f + 1e-3f);
  }
  EXPECT_GT(frame.bytes, 0u);
  // The simulation runs: later frames follow, each taken once.
  const uint64_t first = frame.sim_frame;
  ASSERT_TRUE(WaitFor([&] { return receiver->TakeLatest(frame) && frame.sim_frame > first; }));
  const ReceiverStats stats = receiver->Stats();
  EXPECT_TRUE(stats.streaming);
  EXPECT_GE(stats.frames, 2u);
  EXPECT_GT(stats.bytes_per_frame, 0);
  EXPECT_EQ(stats.decode_errors, 0u);
  receiver->Stop();
}

TEST_F(FrameReceiverTest, NewStreamOptionsRestartTheStream) {
  ServerProcess server(DYSA_SERVER_BINARY, dir.path(), {"--scene", "seed_basic"});
  ASSERT_TRUE(server.running());
  std::unique_ptr<FrameReceiver> receiver = Receive(server);
  ReceivedFrame frame;
  ASSERT_TRUE(WaitFor([&] { return receiver->TakeLatest(frame); }));
  const uint64_t first_stream = frame.stream_id;

  StreamOptions options;
  options.stride = 4;  // every 4th particle
  options.fields = codec::kPositions;
  receiver->SetStreamOptions(options);
  ASSERT_TRUE(
      WaitFor([&] { return receiver->TakeLatest(frame) && frame.stream_id != first_stream; }));
  EXPECT_EQ(frame.frame.stride, 4u);
  EXPECT_EQ(frame.frame.count, kSeedBasicParticles / 4);
  EXPECT_TRUE(frame.frame.speed.empty());
}

TEST_F(FrameReceiverTest, ReportsALostServerAndReconnectsWhenItReturns) {
  auto server = std::make_unique<ServerProcess>(DYSA_SERVER_BINARY, dir.path(),
                                                std::vector<std::string>{"--scene", "seed_basic"});
  ASSERT_TRUE(server->running());
  const int port = server->port();
  std::unique_ptr<FrameReceiver> receiver = Receive(*server);
  ReceivedFrame frame;
  ASSERT_TRUE(WaitFor([&] { return receiver->TakeLatest(frame); }));
  const uint64_t first_stream = frame.stream_id;

  server.reset();  // SIGTERM: the stream ends with a status
  ASSERT_TRUE(WaitFor([&] { return !receiver->Stats().streaming; }, 10));
  EXPECT_FALSE(receiver->Stats().error.empty());

  server = std::make_unique<ServerProcess>(DYSA_SERVER_BINARY, dir.path(),
                                           std::vector<std::string>{"--scene", "seed_basic"}, port);
  ASSERT_TRUE(server->running());
  ASSERT_TRUE(WaitFor([&] {
    return receiver->TakeLatest(frame) && frame.stream_id != first_stream;
  })) << receiver->Stats().error;
  EXPECT_EQ(frame.frame.count, kSeedBasicParticles);
  EXPECT_GE(receiver->Stats().reconnects, 1u);
  EXPECT_TRUE(receiver->Stats().error.empty());
}

TEST_F(FrameReceiverTest, StopReturnsPromptlyWithoutAServer) {
  ConnectOptions connect;
  connect.address = "127.0.0.1:1";  // nothing listens there
  FrameReceiver receiver(connect, StreamOptions{});
  receiver.Start();
  ASSERT_TRUE(WaitFor([&] { return !receiver.Stats().error.empty(); }, 30));
  EXPECT_FALSE(receiver.Stats().streaming);
  const auto start = Clock::now();
  receiver.Stop();
  EXPECT_LT(std::chrono::duration<double>(Clock::now() - start).count(), 5.0);
}

}  // namespace
}  // namespace dysa::remote
