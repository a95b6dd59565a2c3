// The client's half of a stream's delivery signal (AckFrames, docs/server.md "Budgets and
// detail"): after each complete frame, the count of frames received goes to the server, which
// measures the link from these reports rather than from its write completions (the transport's
// rate). At most one report is in flight; counts that arrive meanwhile collapse into the newest,
// so a slow return path costs one small call per round trip, never a queue. Never blocks the
// reader: calls are asynchronous (gRPC's callback API).
#pragma once

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>

#include "dysa/v1/simulation.grpc.pb.h"

namespace dysa::remote {

class FrameAcknowledger {
 public:
  // `token`: the stream's StreamFramesRequest.ack_token; `bearer`: the authorization metadata
  // value, or empty.
  FrameAcknowledger(std::shared_ptr<grpc::Channel> channel, uint64_t token, std::string bearer);
  ~FrameAcknowledger();  // cancels a report in flight and waits for it
  FrameAcknowledger(const FrameAcknowledger&) = delete;
  FrameAcknowledger& operator=(const FrameAcknowledger&) = delete;

  // A frame was received completely: report the count of frames so far.
  void FrameReceived();
  // A random nonzero token.
  static uint64_t NewToken();

 private:
  void SendLocked();  // mu_ held, no call in flight

  std::unique_ptr<dysa::v1::Simulation::Stub> stub_;
  const uint64_t token_;
  const std::string bearer_;
  std::mutex mu_;
  std::condition_variable idle_;
  uint64_t received_ = 0, reported_ = 0;
  bool in_flight_ = false;
  bool stopped_ = false;  // the server cannot take reports (an older one) or we are closing
  // The latest call's round trip, microseconds (0: none yet), sent with the next report.
  uint32_t rtt_us_ = 0;
  std::chrono::steady_clock::time_point sent_at_;
  // The call in flight (valid while in_flight_).
  std::unique_ptr<grpc::ClientContext> context_;
  dysa::v1::AckFramesRequest request_;
  dysa::v1::AckFramesReply reply_;
};

}  // namespace dysa::remote
