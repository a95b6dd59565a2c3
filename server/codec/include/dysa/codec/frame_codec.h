// Particle frame codec: bounded-error quantisation, prediction against what the decoder already
// has, byte planes and zstd, in chunks that decode independently. FORMAT.md is the wire format.
// No dependency on the solver: frames come in as plain arrays indexed by particle id.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

namespace dysa::codec {

inline constexpr uint32_t kMagic = 0x46535944;  // "DYSF"
// Version 2 added the octahedral velocity encoding, version 3 the detail threshold (a subset of
// the particles by rank, detail_subset.h), version 4 explicit ids (a subset the sender chose, e.g.
// by view: the ids travel in each keyframe); streams without them are still written as version 1,
// so older decoders keep reading them.
inline constexpr uint16_t kVersion = 4;
inline constexpr size_t kHeaderSize = 152;

enum Field : uint32_t {
  kPositions = 1u << 0,
  kSpeed = 1u << 1,
  kVelocity = 1u << 2,
  kDensity = 1u << 3,
};

// How the velocity field is sent (FORMAT.md, "Velocity").
enum class VelocityEncoding : uint8_t {
  // Each of vx, vy, vz quantised over [-velocity_max, velocity_max]: the tightest bound per
  // component, velocity_max / (2^bits - 1).
  kComponents,
  // |v| over [0, velocity_max] plus the direction as two octahedral coordinates (Cigolle et al.
  // 2014, "A Survey of Efficient Representations for Independent Unit Vectors"): the error is
  // relative to the speed, so slow particles keep their direction as well as fast ones.
  kOctahedral,
};

// What one stream carries; chosen by the subscriber. Defaults: positions + speed, 16-bit
// positions, 8-bit speed, a keyframe every 60 frames.
struct StreamConfig {
  uint32_t fields = kPositions | kSpeed;
  int position_bits = 16;  // per axis, 1..24
  int speed_bits = 8;      // 1..16
  int velocity_bits = 12;  // per component, 1..16
  VelocityEncoding velocity_encoding = VelocityEncoding::kComponents;
  int density_bits = 16;       // 1..16
  int keyframe_interval = 60;  // frames; >= 1 (1: every frame is a keyframe)
  uint32_t stride = 1;         // level of detail: send the particles with id % stride == 0
  // Level of detail by rank (detail_subset.h): send the particles whose DetailRank(id) is below
  // it as well; 0: no selection. Nonzero makes the stream format version 3.
  uint32_t detail_threshold = 0;
  // Send the particles FrameInput::ids names (a subset the caller chose, e.g. by view), whatever
  // the stride and threshold (which the header still carries: the threshold as the subset's
  // nominal detail). The ids travel in each keyframe; a frame whose ids differ from the previous
  // one's is a keyframe. Makes the stream format version 4.
  bool explicit_ids = false;
  uint32_t chunk_particles = 1u << 16;  // particles per chunk (bounds a chunk's size)
  int zstd_level = 1;

  // Throws std::invalid_argument naming the field and its allowed range.
  void Validate() const;
  bool operator==(const StreamConfig&) const = default;
};

// One frame as the solver has it. Arrays are indexed by particle id 0 .. count-1 (the caller
// scatters its storage order into id order, or passes `ids`). Positions and velocities are
// interleaved xyz.
struct FrameInput {
  uint64_t step = 0;
  double time = 0;                     // s
  std::array<double, 3> domain_min{};  // m, the box particles are kept in
  std::array<double, 3> domain_max{};
  std::span<const float> positions;   // 3 * count, m
  std::span<const float> velocities;  // 3 * count, m/s; needed for speed and velocity
  std::span<const float> densities;   // count, kg/m^3; needed for density
  // With StreamConfig::explicit_ids: the particles to send, strictly increasing, each < count.
  std::span<const uint32_t> ids;
  // With explicit_ids: when set, every particle's position extremes per axis (the server's
  // Simulation::ReadPositionBounds), which a keyframe's position range is widened to instead of
  // a scan of `positions`; the arrays then need valid entries only at `ids` (a view stream's
  // frame reads only the particles it sends).
  bool has_position_bounds = false;
  std::array<float, 3> position_lo{}, position_hi{};
};

// The decoded content of a frame, in id order of the kept particles: id = k * stride, or ids[k]
// when the frame is a subset by rank (detail_threshold != 0).
struct Frame {
  uint32_t frame_seq = 0;
  uint64_t step = 0;
  double time = 0;
  bool keyframe = false;
  uint32_t count = 0;
  uint32_t stride = 1;
  uint32_t detail_threshold = 0;  // 0: every stride-th particle; else DetailKeeps (detail_subset.h)
  bool explicit_ids = false;      // the ids came with the frame (version 4): any subset
  uint32_t fields = 0;
  VelocityEncoding velocity_encoding = VelocityEncoding::kComponents;
  std::vector<float> positions;   // 3 * count
  std::vector<float> speed;       // count
  std::vector<float> velocities;  // 3 * count
  std::vector<float> densities;   // count
  std::vector<uint32_t> ids;      // count particle ids when detail_threshold != 0 or explicit_ids
  // Largest possible |decoded - original| of each field (of each velocity component), from the
  // header's ranges, bits and velocity encoding.
  std::array<double, 3> position_error{};
  double speed_error = 0;
  double velocity_error = 0;
  double density_error = 0;
};

using Chunk = std::vector<uint8_t>;

class FrameEncoder {
 public:
  explicit FrameEncoder(StreamConfig config);  // throws std::invalid_argument
  const StreamConfig& config() const { return config_; }

  // Encodes a frame as chunks (in parallel over chunks). A keyframe is written for the first
  // frame, every keyframe_interval frames, after RequestKeyframe(), when the particle count
  // changes, and when a value leaves the ranges of the current keyframe.
  std::vector<Chunk> Encode(const FrameInput& frame);
  // The next frame will be a keyframe (a subscriber joined or dropped a frame, a reset).
  void RequestKeyframe() { keyframe_requested_ = true; }
  // Whether the last Encode() wrote a keyframe.
  bool last_was_keyframe() const { return last_was_keyframe_; }
  // Particles in the last frame encoded (after stride and detail threshold).
  uint32_t last_count() const { return count_; }
  // Bytes its buffers hold between frames: the decoder's state it predicts from, recycled
  // buffers and the gathered values (a few values per particle and field).
  size_t buffer_bytes() const;

 private:
  StreamConfig config_;
  bool keyframe_requested_ = true;
  bool last_was_keyframe_ = false;
  uint32_t frame_seq_ = 0;
  uint32_t frames_since_keyframe_ = 0;
  uint32_t count_ = 0;
  std::array<double, 8> lo_{}, hi_{};  // the current keyframe's range of each component
  // The decoder's state: quantised values per component of the frames since the last keyframe,
  // newest first, at most 3 (what delta frames are predicted from).
  std::vector<std::vector<std::vector<uint32_t>>> history_;
  std::vector<std::vector<std::vector<uint32_t>>> spare_;  // recycled buffers
  std::vector<std::vector<float>> values_;                 // gathered source values
  // The ids a frame of detail_threshold keeps, for kept_total_ ids (recomputed when it changes);
  // with explicit ids, the last frame's.
  std::vector<uint32_t> kept_;
  size_t kept_total_ = SIZE_MAX;
};

// Each particle's id: ids[k], or k * stride.
std::vector<uint32_t> ParticleIds(const Frame& frame);

class DecodeError : public std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A chunk's parsed header (src/chunk_header.h), for FrameDecoder's private stages.
struct ChunkHeader;
// The threads that decode a frame's chunks (src/task_pool.h).
class TaskPool;

class FrameDecoder {
 public:
  FrameDecoder();
  ~FrameDecoder();
  // A copy or a moved-to decoder has the state of the stream, and threads of its own.
  FrameDecoder(const FrameDecoder& other);
  FrameDecoder& operator=(const FrameDecoder& other);
  FrameDecoder(FrameDecoder&& other) noexcept;
  FrameDecoder& operator=(FrameDecoder&& other) noexcept;

  // Adds one chunk. Returns the frame once all its chunks have arrived. Throws DecodeError with
  // a clear message for malformed, truncated or hostile input and for a newer format version;
  // the decoder then waits for the next keyframe.
  std::optional<Frame> AddChunk(std::span<const uint8_t> chunk);
  // All chunks of one frame at once, decoded in parallel.
  std::optional<Frame> AddChunks(std::span<const Chunk> chunks);
  // The same, writing a completed frame into `out` and returning true. Reusing one `out` for a
  // stream recycles its buffers: no allocation per frame once sizes settle.
  bool AddChunks(std::span<const Chunk> chunks, Frame& out);
  // True while a delta frame cannot be decoded (no keyframe yet, or a frame was missed).
  bool waiting_for_keyframe() const { return !have_previous_; }

 private:
  // The stages of AddChunks, in order. StartFrame begins the frame of `h` (false, and waiting
  // for a keyframe, when it is a delta frame without its reference); AcceptGroup checks the
  // chunks of that frame from `begin` on and marks them received, returning the end of the
  // group; DecodeGroup decodes them in parallel; FinishFrame completes the frame into `out`.
  bool StartFrame(const ChunkHeader& h, std::span<const uint8_t> chunk);
  size_t AcceptGroup(const ChunkHeader& first, const std::vector<ChunkHeader>& headers,
                     size_t begin);
  void DecodeGroup(const ChunkHeader& first, std::span<const Chunk> chunks,
                   const std::vector<ChunkHeader>& headers, size_t begin, size_t end);
  void FinishFrame(const ChunkHeader& first, Frame& out);

  // The frame being assembled from its chunks.
  std::optional<uint32_t> pending_seq_;
  std::vector<uint8_t> pending_header_;  // its first chunk's header
  std::vector<bool> received_;           // per chunk
  uint32_t chunk_size_ = 0;              // its chunks' particle count (all but the last)
  Frame pending_;
  std::vector<std::vector<uint32_t>> current_;  // its quantised values, per component
  // The last complete frame's header, and the quantised values of up to 3 frames since the last
  // keyframe, newest first (delta frames are predicted from them).
  std::vector<uint8_t> previous_header_;
  std::vector<std::vector<std::vector<uint32_t>>> history_;
  std::vector<std::vector<std::vector<uint32_t>>> spare_;  // recycled buffers
  bool have_previous_ = false;
  // The ids of the last subset frame decoded, and what they were computed for.
  std::vector<uint32_t> ids_;
  uint64_t ids_key_[3] = {0, 0, 0};  // count, stride, threshold
  // Started with the first frame of more than one chunk; threads that sleep between frames.
  std::unique_ptr<TaskPool> workers_;
};

}  // namespace dysa::codec
