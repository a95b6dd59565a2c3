// Frames from the messages of a StreamFrames call: each message's chunks go to a
// codec::FrameDecoder, and the message that ends a frame hands it over decoded, with its size on
// the wire and its latency. Shared by every reader of the stream (dysa watch, dysa record and
// FrameReceiver, the viewer's), which differ only in what they do with a frame.
#pragma once

#include <cstdint>

#include "dysa/client/types.h"
#include "dysa/codec/frame_codec.h"

namespace dysa::remote {

// What one message did.
struct FrameProgress {
  bool complete = false;      // the message ended a frame and it decoded: `out` holds it
  bool decode_error = false;  // a chunk could not be decoded; the decoder waits for a keyframe
  // Of the frame the message ended (complete or not): the server's frame_bytes, or the chunk
  // bytes counted here when the server sent none. 0 when the message did not end a frame.
  uint64_t frame_bytes = 0;
  // From the server producing the frame to now, when complete and the server sent the time.
  double latency_ms = 0;
  // A view stream's progressive completion: the completed frame in `out` is the frame shown
  // before plus the particles this one refined it with (codec::MergeRefinement); `partial`: it
  // still lacks particles of the full frame.
  bool refined = false;
  bool partial = false;
  uint64_t stream_id = 0;  // the call's id, once a message carried it
};

class FrameAssembler {
 public:
  // Adds one message. A completed frame is written into `out`, whose buffers are reused (no
  // allocation per frame once sizes settle); the decoder writes every element of it.
  FrameProgress Add(const FrameMessage& message, codec::Frame& out);

 private:
  codec::FrameDecoder decoder_;
  uint64_t pending_bytes_ = 0;  // chunk bytes of the frame being assembled
  uint64_t stream_id_ = 0;
  // A partial frame as shown, which refinements add to (kept only while frames are partial).
  codec::Frame shown_;
  bool have_shown_ = false;
  uint64_t shown_sim_frame_ = 0;
  codec::Frame increment_;  // a refinement as decoded
};

// Microseconds since the Unix epoch, the clock of FrameMessage::produced_unix_us.
int64_t NowUnixMicros();

}  // namespace dysa::remote
