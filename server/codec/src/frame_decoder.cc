// FrameDecoder: chunks are grouped into frames (chunking), and each chunk goes back through the
// encoder's stages in reverse (zstd, bit planes, prediction, quantisation), each in a file of its
// own.
#include <algorithm>
#include <memory>
#include <span>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "bit_planes.h"
#include "byte_io.h"
#include "chunk_header.h"
#include "chunking.h"
#include "components.h"
#include "dysa/codec/detail_subset.h"
#include "dysa/codec/frame_codec.h"
#include "octahedral_velocity.h"
#include "prediction.h"
#include "quantisation.h"
#include "task_pool.h"
#include "zstd_payload.h"

namespace dysa::codec {
namespace {

std::vector<ChunkHeader> ReadHeaders(std::span<const Chunk> chunks) {
  std::vector<ChunkHeader> headers;
  headers.reserve(chunks.size());
  for (const Chunk& chunk : chunks) headers.push_back(ReadHeader(chunk));
  return headers;
}

// The frame's metadata from its header, and its arrays sized for it: without zeroing when the
// size is unchanged, as every value is overwritten.
void StartFrameOutput(const ChunkHeader& h, Frame& frame) {
  frame.frame_seq = h.frame_seq;
  frame.step = h.step;
  frame.time = h.time;
  frame.keyframe = h.keyframe();
  frame.count = h.count;
  frame.stride = h.stride;
  frame.detail_threshold = h.detail_threshold;
  frame.explicit_ids = h.explicit_ids();
  frame.fields = h.fields;
  frame.velocity_encoding =
      h.octahedral() ? VelocityEncoding::kOctahedral : VelocityEncoding::kComponents;
  frame.positions.resize(3 * size_t(h.count));
  frame.speed.resize((h.fields & kSpeed) ? h.count : 0);
  frame.velocities.resize((h.fields & kVelocity) ? 3 * size_t(h.count) : 0);
  frame.densities.resize((h.fields & kDensity) ? h.count : 0);
  if (h.ids_in_payload()) frame.ids.resize(h.count);
}

// The chunk's ids from their gaps (FORMAT.md, "Ids"). False when one reaches the decoder's limit.
bool UndoIdGaps(const ChunkHeader& h, const uint32_t* z, Frame& frame) {
  uint64_t id = 0;
  for (uint32_t k = 0; k < h.chunk_particles; ++k) {
    id = k == 0 ? z[0] : id + uint64_t{z[k]} + 1;
    if (id >= kMaxIds) return false;
    frame.ids[h.first + k] = uint32_t(id);
  }
  return true;
}

// Decodes one chunk into q (quantised values, per component, frame-sized) and the frame's float
// arrays. Chunks of a frame write disjoint ranges, so they run in parallel. Returns an error
// message, empty on success (no exceptions inside parallel loops).
std::string DecodeChunk(const ChunkHeader& h, const Chunk& chunk, Values& q, const History& history,
                        Frame& frame) {
  const std::span<const uint8_t> payload(chunk.data() + kHeaderSize, h.payload_size);
  const std::span<const uint8_t> bits(payload.data() + payload.size(), h.bits_size);
  const int n = ComponentCount(h) + (h.ids_in_payload() ? 1 : 0);
  const uint32_t m = h.chunk_particles;
  // Per-thread scratch, kept between calls.
  thread_local std::vector<uint8_t> raw;
  thread_local std::vector<uint32_t> z;
  if (std::string error = Decompress(payload, h.raw_size, MaxRawSize(n, m), raw); !error.empty()) {
    return error;
  }
  PlaneLayout layout;
  if (std::string error = ReadPlaneLayout(raw, bits.size(), n, m, layout); !error.empty()) {
    return error;
  }
  z.resize(m);
  int slot = 0;
  for (int ci = 0; ci < kComponents; ++ci) {
    const auto c = Component(ci);
    if (!h.Has(c)) continue;
    if (std::string error = ReadResiduals(raw, bits, layout, slot++, m, z.data()); !error.empty()) {
      return error;
    }
    if (!UndoResiduals(h, c, z.data(), history, q)) return "decoded value outside its range";
    // The octahedral velocity needs all three of its components: below.
    if (!(h.octahedral() && IsVelocity(c))) DequantizeComponent(h, c, q, frame);
  }
  if (h.octahedral()) DequantizeOctahedral(h, q, frame);
  if (h.ids_in_payload()) {
    if (std::string error = ReadResiduals(raw, bits, layout, slot, m, z.data()); !error.empty()) {
      return error;
    }
    if (!UndoIdGaps(h, z.data(), frame)) return "particle id over the limit";
  }
  return {};
}

// Threads besides the caller's that decode a frame's chunks: up to 7, fewer on a smaller
// machine. A 1M-particle frame is 16 chunks of 65,536 particles, about 0.3 ms each.
int DecodeWorkers() {
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  return int(std::min(cores, 8u)) - 1;
}

}  // namespace

FrameDecoder::FrameDecoder() = default;
FrameDecoder::~FrameDecoder() = default;
// The stream's state is copied; the threads are the decoder's own, started when first needed.
FrameDecoder::FrameDecoder(const FrameDecoder& other)
    : pending_seq_(other.pending_seq_),
      pending_header_(other.pending_header_),
      received_(other.received_),
      chunk_size_(other.chunk_size_),
      pending_(other.pending_),
      current_(other.current_),
      previous_header_(other.previous_header_),
      history_(other.history_),
      spare_(other.spare_),
      have_previous_(other.have_previous_),
      ids_(other.ids_) {
  std::copy(other.ids_key_, other.ids_key_ + 3, ids_key_);
}
FrameDecoder& FrameDecoder::operator=(const FrameDecoder& other) {
  if (this != &other) {
    FrameDecoder copy(other);
    *this = std::move(copy);
  }
  return *this;
}
FrameDecoder::FrameDecoder(FrameDecoder&& other) noexcept = default;
FrameDecoder& FrameDecoder::operator=(FrameDecoder&& other) noexcept = default;

std::optional<Frame> FrameDecoder::AddChunk(std::span<const uint8_t> chunk) {
  const Chunk copy(chunk.begin(), chunk.end());
  return AddChunks(std::span<const Chunk>(&copy, 1));
}

std::optional<Frame> FrameDecoder::AddChunks(std::span<const Chunk> chunks) {
  Frame frame;
  if (!AddChunks(chunks, frame)) return std::nullopt;
  return frame;
}

bool FrameDecoder::AddChunks(std::span<const Chunk> chunks, Frame& out) {
  const std::vector<ChunkHeader> headers = ReadHeaders(chunks);
  bool done = false;
  // Chunks are taken in order; each group of consecutive chunks of one frame decodes in
  // parallel. A frame left incomplete when the next one starts is dropped.
  size_t begin = 0;
  while (begin < chunks.size()) {
    const ChunkHeader& h = headers[begin];
    if ((!pending_seq_ || *pending_seq_ != h.frame_seq) && !StartFrame(h, chunks[begin])) {
      ++begin;
      continue;
    }
    const ChunkHeader first = ReadHeader(pending_header_);
    const size_t end = AcceptGroup(first, headers, begin);
    DecodeGroup(first, chunks, headers, begin, end);
    begin = end;
    if (std::find(received_.begin(), received_.end(), false) != received_.end()) continue;
    FinishFrame(first, out);
    done = true;
  }
  return done;
}

bool FrameDecoder::StartFrame(const ChunkHeader& h, std::span<const uint8_t> chunk) {
  if (pending_seq_) have_previous_ = false;  // the incomplete frame is lost
  pending_seq_.reset();
  if (!h.keyframe()) {
    bool reference_ok = have_previous_;
    if (reference_ok) {
      const ChunkHeader previous = ReadHeader(previous_header_);
      reference_ok = previous.frame_seq + 1 == h.frame_seq && previous.SameLayout(h);
    }
    if (!reference_ok) {
      have_previous_ = false;  // wait for a keyframe
      return false;
    }
  }
  pending_seq_ = h.frame_seq;
  pending_header_.assign(chunk.begin(), chunk.begin() + kHeaderSize);
  Put<uint32_t>(pending_header_.data() + 140, 0);  // a header alone: no payload
  Put<uint32_t>(pending_header_.data() + 144, 0);
  received_.assign(h.chunk_count, false);
  chunk_size_ = 0;
  StartFrameOutput(h, pending_);
  if (!current_.empty()) spare_.push_back(std::move(current_));
  current_ = TakeValues(spare_, h.count, h);
  return true;
}

size_t FrameDecoder::AcceptGroup(const ChunkHeader& first, const std::vector<ChunkHeader>& headers,
                                 size_t begin) {
  // Check the whole group before marking anything received, so a bad chunk leaves the pending
  // frame as it was.
  std::vector<uint16_t> group;
  size_t end = begin;
  while (end < headers.size() && headers[end].frame_seq == first.frame_seq) {
    const ChunkHeader& h = headers[end];
    CheckChunkRange(h, chunk_size_);
    CheckSameFrame(h, first);
    if (received_[h.chunk_index] ||
        std::find(group.begin(), group.end(), h.chunk_index) != group.end()) {
      throw DecodeError("chunk " + std::to_string(h.chunk_index) + " of frame " +
                        std::to_string(h.frame_seq) + " received twice");
    }
    group.push_back(h.chunk_index);
    ++end;
  }
  for (uint16_t index : group) received_[index] = true;
  return end;
}

void FrameDecoder::DecodeGroup(const ChunkHeader& first, std::span<const Chunk> chunks,
                               const std::vector<ChunkHeader>& headers, size_t begin, size_t end) {
  std::vector<std::string> errors(end - begin);
  const auto decode = [&](size_t i) {
    const size_t k = begin + i;
    errors[i] = DecodeChunk(headers[k], chunks[k], current_, history_, pending_);
  };
  if (end - begin == 1) {
    decode(0);
  } else {
    if (!workers_) workers_ = std::make_unique<TaskPool>(DecodeWorkers());
    workers_->Run(end - begin, decode);
  }
  for (size_t k = 0; k < errors.size(); ++k) {
    if (!errors[k].empty()) {
      pending_seq_.reset();
      have_previous_ = false;
      throw DecodeError("corrupt chunk " + std::to_string(headers[begin + k].chunk_index) +
                        " of frame " + std::to_string(first.frame_seq) + ": " + errors[k]);
    }
  }
}

// Complete: the frame becomes the reference of the next delta frame.
void FrameDecoder::FinishFrame(const ChunkHeader& first, Frame& out) {
  SetErrorBounds(first, pending_);
  if (first.explicit_ids()) {
    if (first.keyframe()) {
      // Each chunk checked its own ids; the order across chunk boundaries is checked here.
      for (size_t k = 1; k < pending_.ids.size(); ++k) {
        if (pending_.ids[k] <= pending_.ids[k - 1]) {
          have_previous_ = false;
          pending_seq_.reset();
          throw DecodeError("corrupt frame " + std::to_string(first.frame_seq) +
                            ": particle ids do not increase");
        }
      }
      ids_ = pending_.ids;
      std::fill(ids_key_, ids_key_ + 3, 0);  // not the ids of a threshold
    } else {
      pending_.ids = ids_;  // a delta frame has its reference's particles
    }
  } else if (first.detail_threshold != 0) {
    const uint64_t key[3] = {first.count, first.stride, first.detail_threshold};
    if (!std::equal(key, key + 3, ids_key_)) {
      std::fill(ids_key_, ids_key_ + 3, 0);
      if (!FirstKeptIds(first.count, first.stride, first.detail_threshold, kMaxIds, ids_)) {
        have_previous_ = false;
        pending_seq_.reset();
        throw DecodeError("corrupt frame header: count " + std::to_string(first.count) +
                          " is more particles than detail threshold " +
                          std::to_string(first.detail_threshold) + " selects");
      }
      std::copy(key, key + 3, ids_key_);
    }
    pending_.ids = ids_;
  } else {
    pending_.ids.clear();
  }
  PushHistory(history_, std::move(current_), first.keyframe(), spare_);
  current_.clear();
  previous_header_ = pending_header_;
  have_previous_ = true;
  pending_seq_.reset();
  // Hand the frame over and keep the caller's old buffers for the next one.
  std::swap(pending_, out);
}

std::vector<uint32_t> ParticleIds(const Frame& frame) {
  if (frame.detail_threshold != 0 || frame.explicit_ids) return frame.ids;
  std::vector<uint32_t> ids(frame.count);
  for (uint32_t k = 0; k < frame.count; ++k) ids[k] = k * frame.stride;
  return ids;
}

}  // namespace dysa::codec
