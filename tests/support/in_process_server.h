// A dysa server inside the test process, on a free loopback port, with a stub to it: the
// fixture of the service tests that talk real gRPC to one server (server_budget_test,
// ack_frames_test, frame_limit_test), and their helpers.
#pragma once

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "dysa/codec/frame_codec.h"
#include "dysa/core/scene.h"
#include "dysa/service/server.h"
#include "dysa/service/simulation_host.h"
#include "dysa/v1/simulation.grpc.pb.h"

namespace dysa::testing {

// seed_basic with 10^3 = 1000 particles.
inline Scene SmallSeedScene() {
  Scene scene = LoadScene("seed_basic");
  SetParam(scene.params, "particle_quantity", 10);
  return scene;
}

// Paused at the start, one solver thread.
inline service::HostOptions PausedHostOptions() {
  service::HostOptions options;
  options.start_paused = true;
  options.solver_threads = 1;
  return options;
}

class InProcessServer {
 public:
  explicit InProcessServer(service::HostOptions host_options = PausedHostOptions(),
                           Scene scene = SmallSeedScene()) {
    service::ServerOptions server_options;
    server_options.listen = "127.0.0.1:0";
    host_ = std::make_unique<service::SimulationHost>(std::move(scene), host_options);
    server_ = std::make_unique<service::Server>(*host_, server_options);
    stub_ = v1::Simulation::NewStub(grpc::CreateChannel(
        "127.0.0.1:" + std::to_string(server_->port()), grpc::InsecureChannelCredentials()));
  }
  ~InProcessServer() {
    server_.reset();  // the server before the host it serves
    host_.reset();
  }
  InProcessServer(const InProcessServer&) = delete;
  InProcessServer& operator=(const InProcessServer&) = delete;

  v1::Simulation::Stub& stub() { return *stub_; }

 private:
  std::unique_ptr<service::SimulationHost> host_;
  std::unique_ptr<service::Server> server_;
  std::unique_ptr<v1::Simulation::Stub> stub_;
};

// A call's context with a 60 s deadline: long enough for a loaded CI machine, short enough that
// a hang fails the test.
inline std::unique_ptr<grpc::ClientContext> Context() {
  auto context = std::make_unique<grpc::ClientContext>();
  context->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
  return context;
}

// The first complete frame of a stream (nullopt when the stream ends before one).
inline std::optional<codec::Frame> FirstFrame(grpc::ClientReader<v1::FrameMessage>& reader) {
  codec::FrameDecoder decoder;
  v1::FrameMessage message;
  while (reader.Read(&message)) {
    for (const std::string& chunk : message.chunks()) {
      auto frame = decoder.AddChunk({reinterpret_cast<const uint8_t*>(chunk.data()), chunk.size()});
      if (frame) return frame;
    }
  }
  return std::nullopt;
}

}  // namespace dysa::testing
