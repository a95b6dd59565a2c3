#include "chunk_header.h"

#include <cmath>
#include <cstring>
#include <sstream>
#include <string>

#include "byte_io.h"

namespace dysa::codec {
namespace {

std::string Str(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

}  // namespace

ChunkHeader StreamHeader(const StreamConfig& config) {
  ChunkHeader h;
  h.fields = config.fields;
  h.position_bits = uint8_t(config.position_bits);
  h.speed_bits = (h.fields & kSpeed) ? uint8_t(config.speed_bits) : 0;
  h.velocity_bits = (h.fields & kVelocity) ? uint8_t(config.velocity_bits) : 0;
  h.density_bits = (h.fields & kDensity) ? uint8_t(config.density_bits) : 0;
  if ((h.fields & kVelocity) && config.velocity_encoding == VelocityEncoding::kOctahedral) {
    h.version = 2;
    h.flags = kOctahedralFlag;
  }
  h.stride = config.stride;
  h.detail_threshold = config.detail_threshold;
  if (h.detail_threshold != 0) h.version = 3;
  if (config.explicit_ids) {
    h.version = 4;
    h.flags |= kIdsFlag;
  }
  return h;
}

void SetRanges(const std::array<double, kComponents>& lo, const std::array<double, kComponents>& hi,
               ChunkHeader& h) {
  for (int a = 0; a < 3; ++a) h.position_min[a] = lo[a], h.position_max[a] = hi[a];
  if (h.fields & kSpeed) h.speed_max = hi[kSpeedC];
  if (h.fields & kVelocity) h.velocity_max = hi[kVelX];
  if (h.fields & kDensity) h.density_min = lo[kDensityC], h.density_max = hi[kDensityC];
}

std::vector<Component> PresentComponents(const ChunkHeader& h) {
  std::vector<Component> comps;
  for (int c = 0; c < kComponents; ++c) {
    if (h.Has(Component(c))) comps.push_back(Component(c));
  }
  return comps;
}

int ComponentCount(const ChunkHeader& h) {
  int n = 0;
  for (int c = 0; c < kComponents; ++c) n += h.Has(Component(c)) ? 1 : 0;
  return n;
}

void WriteHeader(const ChunkHeader& h, uint8_t* out) {
  std::memset(out, 0, kHeaderSize);
  Put<uint32_t>(out + 0, kMagic);
  Put<uint16_t>(out + 4, h.version);
  Put<uint16_t>(out + 6, h.flags);
  Put<uint32_t>(out + 8, h.frame_seq);
  Put<uint32_t>(out + 12, h.count);
  Put<uint64_t>(out + 16, h.step);
  Put<double>(out + 24, h.time);
  Put<uint16_t>(out + 32, h.chunk_index);
  Put<uint16_t>(out + 34, h.chunk_count);
  Put<uint32_t>(out + 36, h.first);
  Put<uint32_t>(out + 40, h.chunk_particles);
  Put<uint32_t>(out + 44, h.fields);
  out[48] = h.position_bits;
  out[49] = h.speed_bits;
  out[50] = h.velocity_bits;
  out[51] = h.density_bits;
  Put<uint32_t>(out + 52, h.stride);
  for (int a = 0; a < 3; ++a) {
    Put<double>(out + 56 + 8 * a, h.position_min[a]);
    Put<double>(out + 80 + 8 * a, h.position_max[a]);
  }
  Put<double>(out + 104, h.speed_max);
  Put<double>(out + 112, h.velocity_max);
  Put<double>(out + 120, h.density_min);
  Put<double>(out + 128, h.density_max);
  Put<uint32_t>(out + 136, h.raw_size);
  Put<uint32_t>(out + 140, h.payload_size);
  Put<uint32_t>(out + 144, h.bits_size);
  Put<uint32_t>(out + 148, h.detail_threshold);
}

ChunkHeader ReadHeader(std::span<const uint8_t> chunk) {
  if (chunk.size() < kHeaderSize) {
    throw DecodeError("truncated chunk: " + std::to_string(chunk.size()) +
                      " bytes, the header alone is " + std::to_string(kHeaderSize));
  }
  const uint8_t* in = chunk.data();
  if (Get<uint32_t>(in) != kMagic) throw DecodeError("not a DySAQUASIMs frame (bad magic)");
  ChunkHeader h;
  h.version = Get<uint16_t>(in + 4);
  if (h.version < 1 || h.version > kVersion) {
    throw DecodeError("frame format version " + std::to_string(h.version) +
                      (h.version > kVersion ? " is newer than" : " is not supported by") +
                      " this decoder (version " + std::to_string(kVersion) +
                      "); update the client");
  }
  h.flags = Get<uint16_t>(in + 6);
  h.frame_seq = Get<uint32_t>(in + 8);
  h.count = Get<uint32_t>(in + 12);
  h.step = Get<uint64_t>(in + 16);
  h.time = Get<double>(in + 24);
  h.chunk_index = Get<uint16_t>(in + 32);
  h.chunk_count = Get<uint16_t>(in + 34);
  h.first = Get<uint32_t>(in + 36);
  h.chunk_particles = Get<uint32_t>(in + 40);
  h.fields = Get<uint32_t>(in + 44);
  h.position_bits = in[48];
  h.speed_bits = in[49];
  h.velocity_bits = in[50];
  h.density_bits = in[51];
  h.stride = Get<uint32_t>(in + 52);
  for (int a = 0; a < 3; ++a) {
    h.position_min[a] = Get<double>(in + 56 + 8 * a);
    h.position_max[a] = Get<double>(in + 80 + 8 * a);
  }
  h.speed_max = Get<double>(in + 104);
  h.velocity_max = Get<double>(in + 112);
  h.density_min = Get<double>(in + 120);
  h.density_max = Get<double>(in + 128);
  h.raw_size = Get<uint32_t>(in + 136);
  h.payload_size = Get<uint32_t>(in + 140);
  h.bits_size = Get<uint32_t>(in + 144);
  h.detail_threshold = Get<uint32_t>(in + 148);
  if (h.version < 3 && h.detail_threshold != 0) {
    throw DecodeError("corrupt frame header: reserved bytes set");
  }

  auto fail = [](const std::string& what) { throw DecodeError("corrupt frame header: " + what); };
  const uint16_t known_flags = h.version >= 4   ? (kKeyframeFlag | kOctahedralFlag | kIdsFlag)
                               : h.version >= 2 ? (kKeyframeFlag | kOctahedralFlag)
                                                : kKeyframeFlag;
  if ((h.flags & ~known_flags) != 0) {
    fail("unknown flags " + std::to_string(h.flags) + " for version " + std::to_string(h.version));
  }
  if (h.octahedral() && !(h.fields & kVelocity)) fail("octahedral flag without velocity");
  if (!(h.fields & kPositions) || (h.fields & ~0xFu) != 0) {
    fail("fields " + std::to_string(h.fields) + " (positions must be present, bits 0-3 only)");
  }
  if (h.count > kMaxCount) fail("count " + std::to_string(h.count) + " over the limit");
  if (h.stride == 0) fail("stride 0");
  if (h.chunk_count == 0 || h.chunk_index >= h.chunk_count) fail("chunk index out of range");
  if (uint64_t{h.first} + h.chunk_particles > h.count) fail("chunk particles out of range");
  if (h.count > 0 && h.chunk_particles == 0) fail("empty chunk");
  if (h.chunk_particles > 0 && !std::isfinite(h.time)) fail("time is not finite");
  for (int c = 0; c < kComponents; ++c) {
    const auto comp = Component(c);
    const int bits = h.Bits(comp);
    const int max_bits = comp <= kPosZ ? 24 : 16;
    if (!h.Has(comp)) {
      if (bits != 0 && comp != kVelY && comp != kVelZ) fail("bits set for an absent field");
      continue;
    }
    if (bits < 1 || bits > max_bits) fail("bit width " + std::to_string(bits));
    const double lo = h.Lo(comp), hi = h.Hi(comp);
    if (!std::isfinite(lo) || !std::isfinite(hi) || !(hi > lo) || !std::isfinite(hi - lo)) {
      fail("range [" + Str(lo) + ", " + Str(hi) + "]");
    }
  }
  if (kHeaderSize + uint64_t{h.payload_size} + h.bits_size != chunk.size()) {
    throw DecodeError("truncated or oversized chunk: header says " +
                      std::to_string(uint64_t{h.payload_size} + h.bits_size) + " payload bytes, " +
                      std::to_string(chunk.size() - kHeaderSize) + " present");
  }
  return h;
}

}  // namespace dysa::codec
