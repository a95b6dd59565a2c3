// The transport side of StreamFrames: each encoded frame serialised once as FrameMessages shared
// by every subscriber of its stream configuration (a reference-counted slice each), and the
// reactor of one StreamFrames call, which sends them. A subscriber costs the server no copy and
// no serialisation of its own.
#pragma once

#include <grpcpp/support/byte_buffer.h>
#include <grpcpp/support/server_callback.h>
#include <grpcpp/support/status.h>

#include <atomic>
#include <cstddef>
#include <memory>
#include <mutex>
#include <string>

#include "dysa/service/frame_hub.h"
#include "dysa/service/write_starter.h"

namespace dysa::service {

// The hub's transport builder (FrameHub::set_transport_builder): a frame as serialised
// FrameMessages, each at most a few MiB of chunks, in EncodedFrame::transport.
std::shared_ptr<const void> BuildWireFrame(const EncodedFrame& frame);

struct WireFrame;

// One StreamFrames call: takes the newest decodable frame from its subscription whenever no
// write is in flight, and sends its messages one after the other. A new frame's first write is
// started on the WriteStarter's thread, the others on gRPC's (OnWriteDone). Deletes itself in
// OnDone.
class FrameStreamReactor final : public grpc::ServerWriteReactor<grpc::ByteBuffer>,
                                 public FrameListener,
                                 private WriteStarter::Writer {
 public:
  FrameStreamReactor(FrameHub& hub, WriteStarter& starter) : hub_(hub), starter_(starter) {}

  // Subscribes, or finishes the call with the reason it cannot.
  void Begin(const SubscriptionOptions& options);
  void FinishNow(const grpc::Status& status);

  // On the simulation's thread: no lock of ours (a gRPC thread may hold it inside StartWrite).
  void OnFrameReady() override {
    new_frame_ = true;
    starter_.Schedule(this);
  }
  void OnMayWrite() override { starter_.Schedule(this); }
  void OnHubClosed() override;
  void OnRefused(const std::string& why) override;

  void OnWriteDone(bool ok) override;
  void OnCancel() override;
  void OnDone() override;

 private:
  void StartNextWrite() override;
  void FinishLocked(const grpc::Status& status);
  // The next message of the current frame, or the first of the next frame.
  void WriteNextLocked();

  FrameHub& hub_;
  WriteStarter& starter_;
  std::shared_ptr<Subscription> subscription_;
  std::mutex mu_;
  bool writing_ = false;
  bool finished_ = false;
  bool closing_ = false;
  bool cancelled_ = false;
  // A new frame came since the last StartNextWrite (not a retry of a held one).
  std::atomic<bool> new_frame_{false};
  std::string refusal_;                        // OnRefused's reason: the stream ends with it
  std::shared_ptr<const EncodedFrame> frame_;  // being sent; owns wire_
  const WireFrame* wire_ = nullptr;
  size_t next_message_ = 0;
  bool id_sent_ = false;      // FrameMessage.stream_id went out (with the first frame)
  grpc::ByteBuffer message_;  // the write in flight
};

}  // namespace dysa::service
