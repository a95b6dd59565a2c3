#include "chunking.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace dysa::codec {

ChunkLayout LayOutChunks(size_t ids, const StreamConfig& config, size_t kept) {
  if (ids > kMaxIds || (config.detail_threshold == 0 ? ids / config.stride : kept) > kMaxCount)
    throw std::invalid_argument("count over the limit of 20,000,000 particles a frame");
  ChunkLayout layout;
  const uint32_t stride = config.stride;
  layout.count = config.detail_threshold != 0 || config.explicit_ids
                     ? uint32_t(kept)
                     : uint32_t((ids + stride - 1) / stride);
  layout.per_chunk = config.chunk_particles;
  layout.chunk_count =
      std::max<uint32_t>(1, (layout.count + layout.per_chunk - 1) / layout.per_chunk);
  if (layout.chunk_count > 0xFFFF)
    throw std::invalid_argument("chunk_particles too small: > 65535 chunks");
  return layout;
}

ChunkHeader ChunkHeaderOf(const ChunkHeader& frame, const ChunkLayout& layout, uint32_t index) {
  ChunkHeader h = frame;
  h.chunk_index = uint16_t(index);
  h.first = index * layout.per_chunk;
  h.chunk_particles = std::min(layout.per_chunk, layout.count - std::min(layout.count, h.first));
  return h;
}

// Checking every chunk against the layout (P is learnt from the first chunk that shows it) means
// the chunks of a frame cover it exactly once: no particle is left undecoded and no two chunks
// write the same values.
void CheckChunkRange(const ChunkHeader& h, uint32_t& chunk_size) {
  const bool last = h.chunk_index + 1 == h.chunk_count;
  const uint32_t m = h.chunk_particles;
  bool ok = last ? uint64_t{h.first} + m == h.count : m > 0;
  uint32_t size = 0;  // the P this chunk implies; 0: none (a frame of one chunk)
  if (!last) {
    size = m;
  } else if (h.chunk_index > 0) {
    ok &= h.first % h.chunk_index == 0;
    size = h.first / h.chunk_index;
  }
  if (size != 0) {
    ok &= uint64_t{size} * h.chunk_index == h.first && (chunk_size == 0 || chunk_size == size);
    ok &= !last || m <= size;
  } else {
    ok &= h.first == 0;
  }
  if (!ok) {
    throw DecodeError("chunk " + std::to_string(h.chunk_index) + " of frame " +
                      std::to_string(h.frame_seq) + " covers particles [" +
                      std::to_string(h.first) + ", " + std::to_string(uint64_t{h.first} + m) +
                      "), which does not fit the frame's other chunks");
  }
  if (size != 0) chunk_size = size;
}

void CheckSameFrame(const ChunkHeader& h, const ChunkHeader& first) {
  if (h.flags != first.flags || h.count != first.count || h.step != first.step ||
      h.chunk_count != first.chunk_count || !h.SameLayout(first) || !(h.time == first.time)) {
    throw DecodeError("chunk " + std::to_string(h.chunk_index) +
                      " does not match the other chunks of frame " + std::to_string(h.frame_seq));
  }
}

}  // namespace dysa::codec
