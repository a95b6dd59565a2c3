#include "frame_acknowledger.h"

#include <algorithm>
#include <random>

namespace dysa::remote {

FrameAcknowledger::FrameAcknowledger(std::shared_ptr<grpc::Channel> channel, uint64_t token,
                                     std::string bearer)
    : stub_(dysa::v1::Simulation::NewStub(std::move(channel))),
      token_(token),
      bearer_(std::move(bearer)) {}

FrameAcknowledger::~FrameAcknowledger() {
  std::unique_lock lock(mu_);
  stopped_ = true;
  if (in_flight_) context_->TryCancel();
  idle_.wait(lock, [&] { return !in_flight_; });
}

uint64_t FrameAcknowledger::NewToken() {
  std::random_device device;
  const uint64_t token = (uint64_t(device()) << 32) ^ device();
  return token != 0 ? token : 1;
}

void FrameAcknowledger::FrameReceived() {
  std::lock_guard lock(mu_);
  ++received_;
  if (!in_flight_ && !stopped_) SendLocked();
}

void FrameAcknowledger::SendLocked() {
  in_flight_ = true;
  reported_ = received_;
  context_ = std::make_unique<grpc::ClientContext>();
  if (!bearer_.empty()) context_->AddMetadata("authorization", bearer_);
  // A report that takes this long is stale anyway; the next one says more.
  context_->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(5));
  request_.set_ack_token(token_);
  request_.set_frames(reported_);
  request_.set_rtt_us(rtt_us_);
  sent_at_ = std::chrono::steady_clock::now();
  stub_->async()->AckFrames(context_.get(), &request_, &reply_, [this](grpc::Status status) {
    std::lock_guard lock(mu_);
    in_flight_ = false;
    if (status.ok()) {
      const auto us = std::chrono::duration_cast<std::chrono::microseconds>(
                          std::chrono::steady_clock::now() - sent_at_)
                          .count();
      rtt_us_ = uint32_t(std::clamp<int64_t>(us, 1, UINT32_MAX));
    }
    // An older server has no AckFrames; a stream that ended has no token: stop reporting.
    if (status.error_code() == grpc::StatusCode::UNIMPLEMENTED ||
        status.error_code() == grpc::StatusCode::NOT_FOUND) {
      stopped_ = true;
    }
    if (!stopped_ && received_ > reported_) {
      SendLocked();
    } else {
      idle_.notify_all();
    }
  });
}

}  // namespace dysa::remote
