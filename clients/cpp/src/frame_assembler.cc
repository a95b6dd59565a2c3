#include "dysa/client/frame_assembler.h"

#include <chrono>

namespace dysa::remote {

int64_t NowUnixMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

FrameProgress FrameAssembler::Add(const FrameMessage& message, codec::Frame& out) {
  FrameProgress progress;
  for (const codec::Chunk& chunk : message.chunks) pending_bytes_ += chunk.size();
  bool decoded = false;
  try {
    decoded = decoder_.AddChunks(message.chunks, out);
  } catch (const codec::DecodeError&) {
    // The decoder waits for the next keyframe, which the server sends after a gap.
    progress.decode_error = true;
  }
  if (!message.last_of_frame) return progress;
  progress.frame_bytes = message.frame_bytes ? message.frame_bytes : pending_bytes_;
  pending_bytes_ = 0;
  if (!decoded) return progress;
  progress.complete = true;
  progress.latency_ms =
      message.produced_unix_us ? double(NowUnixMicros() - message.produced_unix_us) / 1e3 : 0.0;
  return progress;
}

}  // namespace dysa::remote
