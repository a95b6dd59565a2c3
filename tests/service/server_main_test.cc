// Tests of dysa-server as a process (server/service/server_main.cc): SIGTERM and SIGINT end it
// within 2 s whatever runs, a long Step or frames streamed to a reader that stopped reading (a
// container is killed 10 s after SIGTERM; the issue measured 47-65 s during `dysa step 10000`).
// The exit that does not wait for a step still running is shutdown_signal_test's. Also: the
// memory of closed streams goes back to the system.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <signal.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "dysa/v1/simulation.grpc.pb.h"
#include "support/server_process.h"
#include "support/temp_dir.h"
#include "support/wait_for.h"

#ifndef DYSA_SERVER_BINARY
#error "tests/CMakeLists.txt defines DYSA_SERVER_BINARY"
#endif

namespace dysa {
namespace {

// The bound the issue asks for, from the signal to the exit.
constexpr double kShutdownSeconds = 2.0;

std::unique_ptr<v1::Simulation::Stub> Connect(const testing::ServerProcess& server) {
  return v1::Simulation::NewStub(
      grpc::CreateChannel(server.address(), grpc::InsecureChannelCredentials()));
}

uint64_t Frame(v1::Simulation::Stub& stub) {
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
  v1::Status status;
  return stub.GetStatus(&context, {}, &status).ok() ? status.frame() : 0;
}

// The thesis scene, 91,125 particles on one thread: 10,000 frames are many minutes of work.
TEST(ServerMainTest, SigtermDuringALongStepEndsTheServerWithinTwoSeconds) {
  const testing::TempDir dir("server_main_step");
  testing::ServerProcess server(DYSA_SERVER_BINARY, dir.path(),
                                {"--scene", "seed_test_scene", "--paused", "--frame-rate", "0"});
  ASSERT_TRUE(server.running());
  auto stub = Connect(server);
  grpc::Status step_status;
  std::thread stepping([&] {
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(120));
    v1::StepRequest step;
    step.set_count(10000);
    v1::ControlReply reply;
    step_status = stub->Step(&context, step, &reply);
  });
  EXPECT_TRUE(testing::WaitFor([&] { return Frame(*stub) >= 1; }));
  const double seconds = server.StopTimed(SIGTERM, 60);
  stepping.join();
  EXPECT_LT(seconds, kShutdownSeconds) << server.log();
  EXPECT_EQ(step_status.error_code(), grpc::StatusCode::UNAVAILABLE) << step_status.error_message();
  EXPECT_NE(server.log().find("stopped"), std::string::npos) << server.log();
}

TEST(ServerMainTest, SigintWhileRunningWithAStalledReaderEndsTheServerWithinTwoSeconds) {
  const testing::TempDir dir("server_main_stalled");
  testing::ServerProcess server(DYSA_SERVER_BINARY, dir.path(),
                                {"--scene", "seed_test_scene", "--frame-rate", "0"});
  ASSERT_TRUE(server.running());
  auto stub = Connect(server);
  // A stream that is never read: its first frames fill the transport's window, and the server's
  // write of the next one waits for a reader that never comes.
  grpc::ClientContext stream_context;
  auto reader = stub->StreamFrames(&stream_context, {});
  const uint64_t start = Frame(*stub);
  EXPECT_TRUE(testing::WaitFor([&] { return Frame(*stub) >= start + 5; }));
  const double seconds = server.StopTimed(SIGINT, 60);
  EXPECT_LT(seconds, kShutdownSeconds) << server.log();
  stream_context.TryCancel();
  reader->Finish();
}

// The resident memory of a process, bytes.
size_t ResidentBytes(pid_t pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return size_t(std::stoull(line.substr(6))) * 1024;
  }
  ADD_FAILURE() << "no VmRSS for process " << pid;
  return 0;
}

// A frame stream kept open after its first whole frame.
struct OpenStream {
  grpc::ClientContext context;
  std::unique_ptr<grpc::ClientReader<v1::FrameMessage>> reader;
};

// Issue 21, defect 7: 64 stream configurations of 27,000 particles took memory (470 MB with the
// history) that stayed in the server after every stream closed. Their buffers must go back.
TEST(ServerMainTest, StreamBuffersGoBackToTheSystemWhenTheirStreamsClose) {
#if defined(__SANITIZE_ADDRESS__)
  // ASan's allocator keeps freed memory in its quarantine instead of returning it (472 MB stayed
  // 467 MB): resident memory measures the glibc allocator's behaviour, which the release suite
  // checks.
  GTEST_SKIP() << "resident memory is ASan's quarantine under AddressSanitizer; the release "
                  "build checks it";
#endif
  const testing::TempDir dir("server_main_streams");
  // Paused, with the shortest history: nothing else grows meanwhile.
  testing::ServerProcess server(
      DYSA_SERVER_BINARY, dir.path(),
      {"--scene", "seed_basic", "--paused", "--history-frames", "1", "--max-subscribers", "64"});
  ASSERT_TRUE(server.running());
  auto stub = Connect(server);
  const auto subscribers = [&] {
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
    v1::Status status;
    return stub->GetStatus(&context, {}, &status).ok() ? status.subscribers() : 99u;
  };
  const auto open = [&](uint32_t i) {
    auto stream = std::make_unique<OpenStream>();
    v1::StreamFramesRequest request;
    for (auto field :
         {v1::FIELD_POSITIONS, v1::FIELD_SPEED, v1::FIELD_VELOCITY, v1::FIELD_DENSITY}) {
      request.add_fields(field);
    }
    request.set_position_bits(1 + i % 24);  // 64 distinct configurations
    request.set_density_bits(1 + i / 24);
    stream->reader = stub->StreamFrames(&stream->context, request);
    v1::FrameMessage message;
    while (stream->reader->Read(&message) && !message.last_of_frame()) {
    }
    EXPECT_TRUE(message.last_of_frame()) << "stream " << i;
    return stream;
  };
  const auto close = [&](std::vector<std::unique_ptr<OpenStream>>& streams) {
    for (auto& stream : streams) stream->context.TryCancel();
    for (auto& stream : streams) stream->reader->Finish();
    streams.clear();
    EXPECT_TRUE(testing::WaitFor([&] { return subscribers() == 0; }));
  };
  // The first stream's lasting costs (the transport, the frame gathering buffers) are not a
  // configuration's.
  std::vector<std::unique_ptr<OpenStream>> streams;
  streams.push_back(open(100));
  close(streams);
  const size_t before = ResidentBytes(server.pid());
  for (uint32_t i = 0; i < 64; ++i) streams.push_back(open(i));
  const size_t opened = ResidentBytes(server.pid());
  close(streams);
  ASSERT_GT(opened, before + (size_t{32} << 20)) << "64 configurations cost little: nothing to see";
  // The buffers go once the hub has seen the last subscriber leave, which may be a moment after
  // the subscriber count reads 0 (a loaded machine): wait for it, within WaitFor's bound.
  size_t after = 0;
  EXPECT_TRUE(testing::WaitFor([&] {
    after = ResidentBytes(server.pid());
    return after - std::min(after, before) < (opened - before) / 4;
  })) << "before "
      << before / 1024 << " KiB, with the streams " << opened / 1024 << " KiB, after "
      << after / 1024 << " KiB";
}

}  // namespace
}  // namespace dysa
