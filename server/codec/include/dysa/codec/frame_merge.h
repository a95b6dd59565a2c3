// Progressive completion on the client: a frame that refines the one shown (FrameMessage.refines)
// carries other particles of the same simulation frame; the frame to show is the union, in id
// order. The particles' values are those decoded, untouched, so once the refinements complete it
// the union is bit-exactly the full-detail frame (the server quantises every subset of a frame
// over the whole frame's range).
#pragma once

#include "dysa/codec/frame_codec.h"

namespace dysa::codec {

// `shown` becomes the union of itself and `more` (disjoint particles of one frame, each with
// ids: ParticleIds), in increasing id order; its metadata becomes `more`'s, its detail threshold
// that of the shown frame's fraction grown by the particles added, and its error bounds the
// larger of the two. Throws std::invalid_argument when the fields differ or an id is in both.
void MergeRefinement(Frame& shown, const Frame& more);

}  // namespace dysa::codec
