#include "frame_stream_reactor.h"

#include <grpcpp/support/slice.h>

#include <chrono>
#include <stdexcept>
#include <string>
#include <vector>

#include "dysa/v1/simulation.pb.h"

namespace dysa::service {
namespace {

// Messages stay under gRPC's 4 MiB default whatever the client's limit; chunks are far smaller
// (65,536 particles each), so a frame is cut at chunk boundaries.
constexpr size_t kMaxMessageBytes = size_t{3} << 20;

// A varint field of FrameMessage on its own: frames_skipped (6) and stream_id (7) differ
// between subscribers of one shared frame.
grpc::Slice VarintField(uint8_t field, uint64_t value) {
  uint8_t bytes[11] = {uint8_t(field << 3)};
  size_t n = 1;
  do {
    bytes[n++] = uint8_t((value & 0x7f) | (value >= 0x80 ? 0x80 : 0));
    value >>= 7;
  } while (value != 0);
  return grpc::Slice(bytes, n);
}

// The time `produced_unix_us` was, on the steady clock (SteadySeconds) at `now`.
double ProducedSteady(double now, int64_t produced_unix_us) {
  const int64_t unix_now = std::chrono::duration_cast<std::chrono::microseconds>(
                               std::chrono::system_clock::now().time_since_epoch())
                               .count();
  return now - 1e-6 * double(unix_now - produced_unix_us);
}

}  // namespace

// A frame as serialised FrameMessages, each at most kMaxMessageBytes of chunks. Only
// frames_skipped and stream_id differ between subscribers: they are appended to a message as
// fields of their own (protobuf fields may come in any order), so the shared slices are never
// copied.
struct WireFrame {
  std::vector<grpc::Slice> messages;
};

std::shared_ptr<const void> BuildWireFrame(const EncodedFrame& frame) {
  auto wire = std::make_shared<WireFrame>();
  v1::FrameMessage message;
  size_t next = 0;
  do {
    message.Clear();
    size_t bytes = 0;
    while (next < frame.chunks.size()) {
      const codec::Chunk& chunk = frame.chunks[next];
      if (message.chunks_size() > 0 && bytes + chunk.size() > kMaxMessageBytes) break;
      message.add_chunks(chunk.data(), chunk.size());
      bytes += chunk.size();
      ++next;
    }
    message.set_frame(frame.frame);
    message.set_last_of_frame(next == frame.chunks.size());
    message.set_frame_bytes(frame.bytes);
    message.set_produced_unix_us(frame.produced_unix_us);
    message.set_refines(frame.refines);
    message.set_partial(frame.partial);
    auto* text = new std::string(message.SerializeAsString());
    wire->messages.emplace_back(
        text->data(), text->size(), [](void* p) { delete static_cast<std::string*>(p); }, text);
  } while (next < frame.chunks.size());
  return wire;
}

void FrameStreamReactor::Begin(const SubscriptionOptions& options) {
  // Held so that a frame published before subscription_ is set waits for it.
  std::lock_guard lock(mu_);
  try {
    subscription_ = hub_.Subscribe(options, this);
  } catch (const SubscriberLimitError& e) {
    FinishLocked({grpc::StatusCode::RESOURCE_EXHAUSTED, e.what()});
  } catch (const std::invalid_argument& e) {  // the hub's own check; ToOptions made it first
    FinishLocked({grpc::StatusCode::INVALID_ARGUMENT, e.what()});
  }
}

void FrameStreamReactor::FinishNow(const grpc::Status& status) {
  std::lock_guard lock(mu_);
  FinishLocked(status);
}

void FrameStreamReactor::OnHubClosed() {
  std::lock_guard lock(mu_);
  closing_ = true;
  if (!writing_) FinishLocked({grpc::StatusCode::UNAVAILABLE, "the server is shutting down"});
}

void FrameStreamReactor::OnRefused(const std::string& why) {
  std::lock_guard lock(mu_);
  refusal_ = why;
  closing_ = true;
  if (!writing_) FinishLocked({grpc::StatusCode::RESOURCE_EXHAUSTED, why});
}

void FrameStreamReactor::OnWriteDone(bool ok) {
  std::lock_guard lock(mu_);
  writing_ = false;
  if (ok && subscription_ && wire_) {
    hub_.BytesDelivered(subscription_, SteadySeconds(), message_.Length(),
                        next_message_ == wire_->messages.size());
  }
  // A write in flight when the call was cancelled can still complete ok: the stream must end
  // here then, not wait for a frame that may never come (a paused server).
  if (!ok || cancelled_) {
    FinishLocked({grpc::StatusCode::CANCELLED, "the stream was cancelled"});
  } else if (closing_ && !refusal_.empty()) {
    FinishLocked({grpc::StatusCode::RESOURCE_EXHAUSTED, refusal_});
  } else if (closing_) {
    FinishLocked({grpc::StatusCode::UNAVAILABLE, "the server is shutting down"});
  } else if (!finished_) {
    WriteNextLocked();
  }
}

void FrameStreamReactor::OnCancel() {
  std::lock_guard lock(mu_);
  cancelled_ = true;
  if (!writing_) FinishLocked({grpc::StatusCode::CANCELLED, "the stream was cancelled"});
}

void FrameStreamReactor::OnDone() {
  if (subscription_) hub_.Unsubscribe(subscription_);  // no OnFrameReady after this returns
  starter_.Forget(this);                               // nor a StartNextWrite after this
  delete this;
}

void FrameStreamReactor::StartNextWrite() {
  std::lock_guard lock(mu_);
  // A new frame is ready while the last one is still being written: the link is behind.
  const bool fresh = new_frame_.exchange(false);
  if (fresh && writing_ && !finished_ && subscription_) {
    hub_.FrameLate(subscription_, SteadySeconds());
  }
  if (!writing_ && !finished_ && subscription_) WriteNextLocked();
}

void FrameStreamReactor::FinishLocked(const grpc::Status& status) {
  if (finished_) return;
  finished_ = true;
  Finish(status);
}

void FrameStreamReactor::WriteNextLocked() {
  grpc::Slice slices[3];
  size_t count = 1;
  if (!wire_ || next_message_ == wire_->messages.size()) {
    // The link is behind its client's reports: the frame waits (a newer one may replace it);
    // the next report calls OnFrameReady.
    if (hub_.HoldFrame(subscription_, SteadySeconds())) {
      wire_ = nullptr;
      return;
    }
    uint32_t skipped = 0;
    frame_ = subscription_->Take(&skipped);
    if (!frame_) {  // OnFrameReady will follow
      wire_ = nullptr;
      return;
    }
    wire_ = static_cast<const WireFrame*>(frame_->transport.get());
    next_message_ = 0;
    const double now = SteadySeconds();
    hub_.FrameStarted(subscription_, now, *frame_, ProducedSteady(now, frame_->produced_unix_us));
    if (skipped > 0) slices[count++] = VarintField(6, skipped);
    // The stream's id once, with its first frame: a message of several slices may cost gRPC a
    // copy, which every frame should not pay.
    if (!id_sent_) slices[count++] = VarintField(7, subscription_->id());
    id_sent_ = true;
  }
  slices[0] = wire_->messages[next_message_++];
  message_ = grpc::ByteBuffer(slices, count);
  writing_ = true;
  StartWrite(&message_);
}

}  // namespace dysa::service
