#include "dysa/client/frame_assembler.h"

#include <chrono>

#include "dysa/codec/frame_merge.h"

namespace dysa::remote {

int64_t NowUnixMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

FrameProgress FrameAssembler::Add(const FrameMessage& message, codec::Frame& out) {
  FrameProgress progress;
  if (message.stream_id != 0) stream_id_ = message.stream_id;
  progress.stream_id = stream_id_;
  for (const codec::Chunk& chunk : message.chunks) pending_bytes_ += chunk.size();
  // A refinement is only meaningful on top of the frame it refines.
  const bool refining = message.refines && have_shown_ && shown_sim_frame_ == message.frame;
  bool decoded = false;
  try {
    decoded = decoder_.AddChunks(message.chunks, refining ? increment_ : out);
  } catch (const codec::DecodeError&) {
    // The decoder waits for the next keyframe, which the server sends after a gap.
    progress.decode_error = true;
  }
  if (!message.last_of_frame) return progress;
  progress.frame_bytes = message.frame_bytes ? message.frame_bytes : pending_bytes_;
  pending_bytes_ = 0;
  if (!decoded || (message.refines && !refining)) return progress;
  if (refining) {
    codec::MergeRefinement(shown_, increment_);
    if (!message.partial) shown_.detail_threshold = 0;  // every particle: full detail
    out = shown_;
    progress.refined = true;
  }
  // Keep the shown frame while more may come to complete it.
  have_shown_ = message.partial;
  if (message.partial && !refining) shown_ = out;
  shown_sim_frame_ = message.frame;
  progress.partial = message.partial;
  progress.complete = true;
  progress.latency_ms =
      message.produced_unix_us ? double(NowUnixMicros() - message.produced_unix_us) / 1e3 : 0.0;
  return progress;
}

}  // namespace dysa::remote
