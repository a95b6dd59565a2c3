// The client side of the soak cases: plain generated stubs over loopback gRPC.
#pragma once

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <thread>

#include "dysa/v1/simulation.grpc.pb.h"

namespace dysa::soak {

// A stub on a connection of its own: a local subchannel pool, so that no two stubs share a TCP
// connection (gRPC shares one between channels to the same address by default), and a stalled
// stream or a closed connection is one client's alone.
inline std::unique_ptr<v1::Simulation::Stub> Connect(const std::string& address) {
  grpc::ChannelArguments args;
  args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
  return v1::Simulation::NewStub(
      grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), args));
}

inline std::unique_ptr<grpc::ClientContext> Context(double seconds) {
  auto context = std::make_unique<grpc::ClientContext>();
  context->set_deadline(std::chrono::system_clock::now() +
                        std::chrono::milliseconds(int64_t(seconds * 1000)));
  return context;
}

inline std::optional<v1::Status> GetStatus(v1::Simulation::Stub& stub, double seconds = 10) {
  v1::Status status;
  if (!stub.GetStatus(Context(seconds).get(), {}, &status).ok()) return std::nullopt;
  return status;
}

// Polls `done` every 10 ms until it holds (true) or `seconds` pass (false).
inline bool WaitFor(const std::function<bool()>& done, double seconds) {
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (!done()) {
    if (std::chrono::steady_clock::now() > give_up) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

inline double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// A frame stream: its context and reader, kept together.
struct OpenStream {
  grpc::ClientContext context;
  std::unique_ptr<grpc::ClientReader<v1::FrameMessage>> reader;
  // Reads until the end of a whole frame; false if the stream ended first.
  bool ReadFrame(v1::FrameMessage* last = nullptr) {
    v1::FrameMessage message;
    while (reader->Read(&message)) {
      if (message.last_of_frame()) {
        if (last) *last = std::move(message);
        return true;
      }
    }
    return false;
  }
  grpc::Status Close() {
    context.TryCancel();
    v1::FrameMessage message;
    while (reader->Read(&message)) {
    }
    return reader->Finish();
  }
};

inline std::unique_ptr<OpenStream> Subscribe(v1::Simulation::Stub& stub,
                                             const v1::StreamFramesRequest& request) {
  auto stream = std::make_unique<OpenStream>();
  stream->reader = stub.StreamFrames(&stream->context, request);
  return stream;
}

// Every field, so that a frame and a stream configuration's buffers are as large as they get.
inline v1::StreamFramesRequest EveryField() {
  v1::StreamFramesRequest request;
  for (auto field : {v1::FIELD_POSITIONS, v1::FIELD_SPEED, v1::FIELD_VELOCITY, v1::FIELD_DENSITY}) {
    request.add_fields(field);
  }
  return request;
}

}  // namespace dysa::soak
