// Prediction (FORMAT.md, "Payload", residuals): each quantised value minus its prediction from
// the previous particle (keyframe) or from the same particle in up to three earlier frames
// (delta frame), zig-zag mapped; and the history of frames both sides predict from.
#pragma once

#include <cstdint>
#include <vector>

#include "chunk_header.h"
#include "components.h"
#include "quantisation.h"

namespace dysa::codec {

// The decoder's state, which the encoder keeps too: the quantised values of the frames since the
// last keyframe, newest first, at most 3 (what delta frames are predicted from). The encoder
// quantises before it predicts, so both sides hold the same values and prediction never drifts.
using History = std::vector<Values>;

// Makes q the newest frame of the history (the only one after a keyframe); buffers that leave
// it go to `spare`.
void PushHistory(History& history, Values&& q, bool keyframe, std::vector<Values>& spare);

// The residuals of component c over the chunk `h` (h.chunk_particles values from h.first),
// zig-zag mapped, into z.
void Residuals(const ChunkHeader& h, Component c, const Values& q, const History& history,
               uint32_t* z);

// The inverse: the chunk's values of component c into q from their zig-zag residuals z. False
// when a value leaves [0, levels].
bool UndoResiduals(const ChunkHeader& h, Component c, const uint32_t* z, const History& history,
                   Values& q);

}  // namespace dysa::codec
