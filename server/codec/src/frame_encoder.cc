// FrameEncoder: a frame goes through the stages of FORMAT.md in order, each in a file of its own
// (gather, quantisation, chunking; then per chunk prediction, bit planes, zstd and the header).
#include <algorithm>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "bit_planes.h"
#include "chunk_header.h"
#include "chunking.h"
#include "components.h"
#include "dysa/codec/detail_subset.h"
#include "dysa/codec/frame_codec.h"
#include "prediction.h"
#include "quantisation.h"
#include "zstd_payload.h"

namespace dysa::codec {
namespace {

// What the chunks of one frame share beyond the stream's header fields and ranges.
void SetFrame(uint32_t frame_seq, bool keyframe, const FrameInput& f, uint32_t stride,
              const ChunkLayout& layout, ChunkHeader& h) {
  h.flags |= keyframe ? kKeyframeFlag : 0;
  h.frame_seq = frame_seq;
  h.count = layout.count;
  h.step = f.step;
  h.time = f.time;
  h.stride = stride;  // detail_threshold comes with StreamHeader
  h.chunk_count = uint16_t(layout.chunk_count);
}

// The chunk on the wire: its header, the zstd payload, then the packed low bits.
Chunk AssembleChunk(ChunkHeader h, size_t raw_size, std::span<const uint8_t> payload,
                    std::span<const uint8_t> low_bits) {
  h.raw_size = uint32_t(raw_size);
  h.payload_size = uint32_t(payload.size());
  h.bits_size = uint32_t(low_bits.size());
  Chunk chunk;
  chunk.reserve(kHeaderSize + payload.size() + low_bits.size());
  chunk.resize(kHeaderSize);
  chunk.insert(chunk.end(), payload.begin(), payload.end());
  chunk.insert(chunk.end(), low_bits.begin(), low_bits.end());
  WriteHeader(h, chunk.data());
  return chunk;
}

// The chunk's ids as FORMAT.md ("Ids") stores them: the first id, then each gap minus one
// (the ids strictly increase), so a dense run of ids costs zero bytes before zstd.
void IdGaps(std::span<const uint32_t> ids, uint32_t first, uint32_t m, uint32_t* z) {
  for (uint32_t k = 0; k < m; ++k) {
    z[k] = k == 0 ? ids[first] : ids[first + k] - ids[first + k - 1] - 1;
  }
}

// Chunk `index` of the frame, from its quantised values q (and the frame's ids, when its payload
// carries them). Returns an error message, empty on success (no exceptions inside the parallel
// loop over chunks).
std::string EncodeChunk(const ChunkHeader& frame, const ChunkLayout& layout, uint32_t index,
                        std::span<const Component> comps, const Values& q, const History& history,
                        std::span<const uint32_t> ids, int zstd_level, Chunk& chunk) {
  const ChunkHeader h = ChunkHeaderOf(frame, layout, index);
  const uint32_t m = h.chunk_particles;
  const size_t slots = comps.size() + (h.ids_in_payload() ? 1 : 0);
  // Per-thread scratch, kept between calls.
  thread_local std::vector<uint32_t> z;
  thread_local std::vector<uint8_t> raw, low_bits, compressed;
  z.resize(size_t(m) * slots);
  for (size_t slot = 0; slot < comps.size(); ++slot) {
    Residuals(h, comps[slot], q, history, z.data() + slot * m);
  }
  if (h.ids_in_payload()) IdGaps(ids, h.first, m, z.data() + comps.size() * m);
  WritePlanes(z.data(), slots, m, raw, low_bits);
  size_t payload = 0;
  if (std::string error = Compress(raw, zstd_level, compressed, payload); !error.empty()) {
    return error;
  }
  chunk = AssembleChunk(h, raw.size(), std::span(compressed).first(payload), low_bits);
  return {};
}

// Every chunk of the frame, in parallel.
std::vector<Chunk> EncodeChunks(const ChunkHeader& frame, const ChunkLayout& layout,
                                std::span<const Component> comps, const Values& q,
                                const History& history, std::span<const uint32_t> ids,
                                int zstd_level) {
  std::vector<Chunk> chunks(layout.chunk_count);
  std::vector<std::string> errors(layout.chunk_count);
#pragma omp parallel for schedule(dynamic, 1)
  for (int64_t i = 0; i < int64_t(layout.chunk_count); ++i) {
    errors[i] =
        EncodeChunk(frame, layout, uint32_t(i), comps, q, history, ids, zstd_level, chunks[i]);
  }
  for (const std::string& error : errors) {
    if (!error.empty()) throw std::runtime_error(error);
  }
  return chunks;
}

}  // namespace

void StreamConfig::Validate() const {
  auto check = [](bool ok, const std::string& field, const std::string& range) {
    if (!ok) throw std::invalid_argument(field + ": allowed range " + range);
  };
  check((fields & kPositions) && (fields & ~0xFu) == 0, "fields",
        "positions plus any of speed, velocity, density");
  check(position_bits >= 1 && position_bits <= 24, "position_bits", "[1, 24]");
  check(speed_bits >= 1 && speed_bits <= 16, "speed_bits", "[1, 16]");
  check(velocity_bits >= 1 && velocity_bits <= 16, "velocity_bits", "[1, 16]");
  check(density_bits >= 1 && density_bits <= 16, "density_bits", "[1, 16]");
  check(keyframe_interval >= 1 && keyframe_interval <= 1000000, "keyframe_interval",
        "[1, 1000000]");
  check(stride >= 1, "stride", "[1, 2^32 - 1]");
  check(chunk_particles >= 1 && chunk_particles <= (1u << 20), "chunk_particles", "[1, 2^20]");
  check(zstd_level >= -7 && zstd_level <= 22, "zstd_level", "[-7, 22]");
  check(velocity_encoding == VelocityEncoding::kComponents ||
            velocity_encoding == VelocityEncoding::kOctahedral,
        "velocity_encoding", "components or octahedral");
}

FrameEncoder::FrameEncoder(StreamConfig config) : config_(config) { config_.Validate(); }

size_t FrameEncoder::buffer_bytes() const {
  size_t bytes = 0;
  for (const auto* frames : {&history_, &spare_}) {
    for (const auto& frame : *frames) {
      for (const auto& component : frame) bytes += component.capacity() * sizeof(uint32_t);
    }
  }
  for (const auto& component : values_) bytes += component.capacity() * sizeof(float);
  bytes += kept_.capacity() * sizeof(uint32_t);
  return bytes;
}

std::vector<Chunk> FrameEncoder::Encode(const FrameInput& f) {
  const size_t ids = CheckInput(f, config_.fields);
  bool subset_changed = false;
  if (config_.explicit_ids) {
    CheckIds(f.ids, ids);
    subset_changed = !std::ranges::equal(f.ids, kept_);
    if (subset_changed) kept_.assign(f.ids.begin(), f.ids.end());
  } else if (config_.detail_threshold != 0 && kept_total_ != ids) {
    kept_ = KeptIds(ids, config_.stride, config_.detail_threshold);
    kept_total_ = ids;
  }
  const bool subset = config_.explicit_ids || config_.detail_threshold != 0;
  const ChunkLayout layout = LayOutChunks(ids, config_, kept_.size());
  ChunkHeader h = StreamHeader(config_);
  const std::vector<Component> comps = PresentComponents(h);
  const std::span<const uint32_t> kept =
      subset ? std::span<const uint32_t>(kept_) : std::span<const uint32_t>();
  Extremes extremes =
      GatherComponents(f, comps, config_.stride, kept, layout.count, h.octahedral(), values_);
  const bool keyframe = keyframe_requested_ || frame_seq_ == 0 || layout.count != count_ ||
                        subset_changed ||
                        frames_since_keyframe_ >= uint32_t(config_.keyframe_interval) ||
                        LeavesRanges(extremes, comps, layout.count, lo_, hi_);
  // A chosen subset's positions are quantised over the range the whole frame would get, so the
  // particles of subsets of one frame decode bit-exactly as the full frame's (the server's
  // progressive completion relies on it).
  if (keyframe && config_.explicit_ids) WidenPositionsToAll(f, extremes);
  if (keyframe) ChooseRanges(f, comps, h.octahedral(), layout.count, extremes, lo_, hi_);
  SetRanges(lo_, hi_, h);
  // The decoder will hold these same values, so prediction from them never drifts.
  Values q = TakeValues(spare_, layout.count, h);
  QuantizeComponents(h, comps, values_, layout.count, q);
  SetFrame(frame_seq_, keyframe, f, config_.stride, layout, h);
  std::vector<Chunk> chunks = EncodeChunks(h, layout, comps, q, history_, kept, config_.zstd_level);
  PushHistory(history_, std::move(q), keyframe, spare_);
  frames_since_keyframe_ = keyframe ? 1 : frames_since_keyframe_ + 1;
  keyframe_requested_ = false;
  last_was_keyframe_ = keyframe;
  count_ = layout.count;
  ++frame_seq_;
  return chunks;
}

}  // namespace dysa::codec
