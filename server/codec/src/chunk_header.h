// The chunk header (FORMAT.md, "Chunk header"): its fields, what they say about each component
// (present or not, bits, range), and its 152 bytes on the wire.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "components.h"
#include "dysa/codec/frame_codec.h"

namespace dysa::codec {

// A decoder never allocates for more particles than this, whatever a header claims: the
// solver's own limit (kMaxParticles in dysa/core/scene.h), about 1 GB of decoder buffers.
inline constexpr uint32_t kMaxCount = 20'000'000;
// A frame by detail threshold (a subset of a larger scene) may name ids up to this: the solver's
// kMaxParticles. A decoder scans at most this many ids for a frame's ids (once per threshold).
inline constexpr uint32_t kMaxIds = 500'000'000;

inline constexpr uint16_t kKeyframeFlag = 1u << 0;
inline constexpr uint16_t kOctahedralFlag = 1u << 1;  // version 2 and later
inline constexpr uint16_t kIdsFlag = 1u << 2;         // version 4: explicit ids (FORMAT.md, "Ids")

struct ChunkHeader {
  uint16_t version = 1;
  uint16_t flags = 0;
  uint32_t frame_seq = 0;
  uint32_t count = 0;
  uint64_t step = 0;
  double time = 0;
  uint16_t chunk_index = 0;
  uint16_t chunk_count = 1;
  uint32_t first = 0;
  uint32_t chunk_particles = 0;
  uint32_t fields = 0;
  uint8_t position_bits = 0, speed_bits = 0, velocity_bits = 0, density_bits = 0;
  uint32_t stride = 1;
  double position_min[3] = {}, position_max[3] = {};
  double speed_max = 0, velocity_max = 0, density_min = 0, density_max = 0;
  uint32_t raw_size = 0;
  uint32_t payload_size = 0;
  uint32_t bits_size = 0;
  uint32_t detail_threshold = 0;  // version 3; the reserved 0 before

  bool keyframe() const { return (flags & kKeyframeFlag) != 0; }
  bool octahedral() const { return (flags & kOctahedralFlag) != 0; }
  bool explicit_ids() const { return (flags & kIdsFlag) != 0; }
  // Whether the payload carries the chunk's ids after the components: keyframes with explicit ids.
  bool ids_in_payload() const { return explicit_ids() && keyframe(); }
  bool Has(Component c) const {
    switch (c) {
      case kPosX:
      case kPosY:
      case kPosZ:
        return true;
      case kSpeedC:
        return fields & kSpeed;
      case kDensityC:
        return fields & kDensity;
      default:
        return fields & kVelocity;
    }
  }
  int Bits(Component c) const {
    if (c <= kPosZ) return position_bits;
    if (c == kSpeedC) return speed_bits;
    if (c == kDensityC) return density_bits;
    return velocity_bits;
  }
  double Lo(Component c) const {
    if (c <= kPosZ) return position_min[c];
    if (c == kSpeedC) return 0.0;
    if (c == kDensityC) return density_min;
    if (octahedral()) return c == kVelX ? 0.0 : -1.0;  // |v|, then the two coordinates
    return -velocity_max;
  }
  double Hi(Component c) const {
    if (c <= kPosZ) return position_max[c];
    if (c == kSpeedC) return speed_max;
    if (c == kDensityC) return density_max;
    if (octahedral()) return c == kVelX ? velocity_max : 1.0;
    return velocity_max;
  }
  // Same stream layout: what a delta frame must share with its reference frame.
  bool SameLayout(const ChunkHeader& o) const {
    return count == o.count && stride == o.stride && detail_threshold == o.detail_threshold &&
           fields == o.fields && octahedral() == o.octahedral() &&
           explicit_ids() == o.explicit_ids() && position_bits == o.position_bits &&
           speed_bits == o.speed_bits && velocity_bits == o.velocity_bits &&
           density_bits == o.density_bits &&
           std::equal(position_min, position_min + 3, o.position_min) &&
           std::equal(position_max, position_max + 3, o.position_max) && speed_max == o.speed_max &&
           velocity_max == o.velocity_max && density_min == o.density_min &&
           density_max == o.density_max;
  }
};

// What a stream's configuration fixes: its fields and bit widths, and the version and flag of
// the octahedral velocity encoding (set first: the velocity ranges depend on it).
ChunkHeader StreamHeader(const StreamConfig& config);

// The current keyframe's range of each present component, as the header carries them.
void SetRanges(const std::array<double, kComponents>& lo, const std::array<double, kComponents>& hi,
               ChunkHeader& h);

// The present components, in payload order.
std::vector<Component> PresentComponents(const ChunkHeader& h);
int ComponentCount(const ChunkHeader& h);

// Writes the kHeaderSize bytes at `out`.
void WriteHeader(const ChunkHeader& h, uint8_t* out);

// Parses and checks everything in a header that does not depend on other chunks; throws
// DecodeError.
ChunkHeader ReadHeader(std::span<const uint8_t> chunk);

}  // namespace dysa::codec
