// Chunking (FORMAT.md: chunk_index, chunk_count, first, chunk_particles): chunk i of a frame
// holds its particles [i P, min((i + 1) P, count)) for one chunk size P per frame, so every
// message stays well under gRPC's limit and each chunk decodes without the others.
#pragma once

#include <cstddef>
#include <cstdint>

#include "chunk_header.h"
#include "dysa/codec/frame_codec.h"

namespace dysa::codec {

struct ChunkLayout {
  uint32_t count = 0;        // particles in the frame, after the stride
  uint32_t per_chunk = 1;    // P
  uint32_t chunk_count = 1;  // >= 1, also for an empty frame
};

// The layout of a frame of `ids` particles, of which `kept` are sent (with a detail threshold;
// without one, every stride-th). Throws std::invalid_argument when ids is over the decoder's limit
// or when the chunks would be more than a header can number.
ChunkLayout LayOutChunks(size_t ids, const StreamConfig& config, size_t kept);

// The header of chunk `index`: the frame's header with the chunk's particle range.
ChunkHeader ChunkHeaderOf(const ChunkHeader& frame, const ChunkLayout& layout, uint32_t index);

// Checks a received chunk's range against the layout above, learning P into `chunk_size` (0
// until a chunk shows it). Throws DecodeError.
void CheckChunkRange(const ChunkHeader& h, uint32_t& chunk_size);

// Checks that chunk `h` belongs with the frame whose first received chunk is `first`: the same
// flags, count, step, time, chunk count and layout. Throws DecodeError.
void CheckSameFrame(const ChunkHeader& h, const ChunkHeader& first);

}  // namespace dysa::codec
