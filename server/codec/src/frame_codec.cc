#include "dysa/codec/frame_codec.h"

#include <zstd.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <sstream>

#include "byte_io.h"

namespace dysa::codec {
namespace {

// Components in payload order (FORMAT.md).
enum Component { kPosX, kPosY, kPosZ, kSpeedC, kVelX, kVelY, kVelZ, kDensityC, kComponents };

// A decoder never allocates for more particles than this, whatever a header claims: the
// solver's own limit (kMaxParticles in dysa/core/scene.h), about 1 GB of decoder buffers.
constexpr uint32_t kMaxCount = 20'000'000;

constexpr uint16_t kKeyframeFlag = 1u << 0;
constexpr uint16_t kOctahedralFlag = 1u << 1;  // version 2 and later

struct Header {
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

  bool keyframe() const { return (flags & kKeyframeFlag) != 0; }
  bool octahedral() const { return (flags & kOctahedralFlag) != 0; }
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
  bool SameLayout(const Header& o) const {
    return count == o.count && stride == o.stride && fields == o.fields &&
           octahedral() == o.octahedral() && position_bits == o.position_bits &&
           speed_bits == o.speed_bits && velocity_bits == o.velocity_bits &&
           density_bits == o.density_bits &&
           std::equal(position_min, position_min + 3, o.position_min) &&
           std::equal(position_max, position_max + 3, o.position_max) && speed_max == o.speed_max &&
           velocity_max == o.velocity_max && density_min == o.density_min &&
           density_max == o.density_max;
  }
};

void WriteHeader(const Header& h, uint8_t* out) {
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
}

std::string Str(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// Parses and checks everything in a header that does not depend on other chunks.
Header ReadHeader(std::span<const uint8_t> chunk) {
  if (chunk.size() < kHeaderSize) {
    throw DecodeError("truncated chunk: " + std::to_string(chunk.size()) +
                      " bytes, the header alone is " + std::to_string(kHeaderSize));
  }
  const uint8_t* in = chunk.data();
  if (Get<uint32_t>(in) != kMagic) throw DecodeError("not a DySAQUASIMs frame (bad magic)");
  Header h;
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
  if (Get<uint32_t>(in + 148) != 0) throw DecodeError("corrupt frame header: reserved bytes set");

  auto fail = [](const std::string& what) { throw DecodeError("corrupt frame header: " + what); };
  const uint16_t known_flags = h.version >= 2 ? (kKeyframeFlag | kOctahedralFlag) : kKeyframeFlag;
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

int ComponentCount(const Header& h) {
  int n = 0;
  for (int c = 0; c < kComponents; ++c) n += h.Has(Component(c)) ? 1 : 0;
  return n;
}

uint32_t Levels(int bits) { return bits >= 32 ? 0xFFFFFFFFu : (1u << bits) - 1; }

// The nearest level (ties up) to v, clamped to [0, levels]; NaN gives 0. `scale` is
// levels / (hi - lo). Branch-free so the loop over a component vectorises.
uint32_t Quantize(double v, double lo, double scale, uint32_t levels) {
  double x = (v - lo) * scale + 0.5;
  x = x >= 0 ? x : 0;  // also NaN
  x = x <= double(levels) ? x : double(levels);
  return uint32_t(x);
}

float Dequantize(uint32_t q, double lo, double step) { return float(lo + double(q) * step); }

// Octahedral unit vectors (FORMAT.md, "Velocity"): the direction n goes to the octahedron
// |x| + |y| + |z| = 1, whose lower half folds over the upper one, then to (u, v) in [-1, 1]^2.
double SignNotZero(double x) { return x >= 0 ? 1.0 : -1.0; }

// (|v|, u, v) of a velocity, in double precision. The zero vector maps to (0, 0, 0).
std::array<double, 3> ToOctahedral(double x, double y, double z) {
  const double magnitude = std::sqrt(x * x + y * y + z * z);
  if (!(magnitude > 0)) return {magnitude, 0.0, 0.0};  // also NaN: quantises to 0
  const double l1 = std::abs(x) + std::abs(y) + std::abs(z);
  const double px = x / l1, py = y / l1;
  if (z >= 0) return {magnitude, px, py};
  return {magnitude, (1.0 - std::abs(py)) * SignNotZero(px),
          (1.0 - std::abs(px)) * SignNotZero(py)};
}

// The decoded velocity: the point of the octahedron at (u, v), scaled to |v| = magnitude. Every
// operation is a double-precision IEEE operation in this order, so the Python decoder gives the
// same floats.
void FromOctahedral(double magnitude, double u, double v, float* out) {
  const double au = std::abs(u), av = std::abs(v);
  const double z = 1.0 - au - av;
  if (z < 0) {
    const double fu = (1.0 - av) * SignNotZero(u);
    const double fv = (1.0 - au) * SignNotZero(v);
    u = fu;
    v = fv;
  }
  const double scale = magnitude / std::sqrt(u * u + v * v + z * z);
  out[0] = float(u * scale);
  out[1] = float(v * scale);
  out[2] = float(z * scale);
}

uint32_t ZigZag(int32_t r) { return (uint32_t(r) << 1) ^ uint32_t(r >> 31); }
int32_t UnZigZag(uint32_t z) { return int32_t(z >> 1) ^ -int32_t(z & 1); }

// The residuals of a component are split at bit k: the high parts z >> k, small and skewed,
// go to zstd as byte planes; the low k bits, close to uniformly random for noisy residuals, are
// packed as they are. k is chosen from the mean so that the high parts average a few units.
int SplitBitsFor(uint64_t sum_z, uint32_t m) {
  const uint64_t mean = m == 0 ? 0 : sum_z / m;
  int bit_length = 0;
  while ((mean >> bit_length) != 0) ++bit_length;
  return std::min(24, std::max(0, bit_length - 3));
}

size_t PackedBytes(uint32_t m, int k) { return (uint64_t(m) * uint64_t(k) + 7) / 8; }

// Appends the low k bits of each value, least significant bit first, padded to whole bytes.
void PackBits(const uint32_t* values, uint32_t m, int k, std::vector<uint8_t>& out) {
  if (k == 0) return;
  const size_t at = out.size();
  out.resize(at + PackedBytes(m, k));
  uint8_t* dst = out.data() + at;
  const uint32_t mask = (1u << k) - 1;
  uint64_t acc = 0;
  int filled = 0;
  for (uint32_t i = 0; i < m; ++i) {
    acc |= uint64_t(values[i] & mask) << filled;
    filled += k;
    while (filled >= 8) {
      *dst++ = uint8_t(acc);
      acc >>= 8;
      filled -= 8;
    }
  }
  if (filled > 0) *dst = uint8_t(acc);
}

int PlanesFor(uint32_t max_z) {
  int planes = 0;
  while (max_z != 0) ++planes, max_z >>= 8;
  return planes;
}

using History = std::vector<std::vector<std::vector<uint32_t>>>;

// Buffers of quantised values: large, allocated once and recycled from frame to frame (fresh
// multi-megabyte allocations cost more in page faults than the coding itself).
using Values = std::vector<std::vector<uint32_t>>;

void PushHistory(History& history, Values&& q, bool keyframe, std::vector<Values>& spare) {
  if (keyframe) {
    for (Values& old : history) spare.push_back(std::move(old));
    history.clear();
  }
  history.insert(history.begin(), std::move(q));
  if (history.size() > 3) {
    spare.push_back(std::move(history.back()));
    history.pop_back();
  }
}

// A recycled buffer (or a new one) sized for `count` values of each component in `fields`.
Values TakeValues(std::vector<Values>& spare, uint32_t count, const std::array<bool, 8>& present) {
  Values q;
  if (!spare.empty()) {
    q = std::move(spare.back());
    spare.pop_back();
  }
  q.resize(8);
  for (int c = 0; c < 8; ++c) {
    if (present[c])
      q[c].resize(count);  // no zeroing when the size is unchanged
    else
      q[c].clear();
  }
  return q;
}

// Copies component c of the kept particles (ids 0, stride, 2 stride, ...) into `out` (count
// values) and returns its extremes. Speed is |v| computed in double and rounded to float; with
// the octahedral encoding the velocity components are |v|, u and v, rounded to float.
std::pair<float, float> GatherComponent(const FrameInput& f, Component c, uint32_t stride,
                                        uint32_t count, bool octahedral, float* out) {
  float mn = std::numeric_limits<float>::infinity();
  float mx = -std::numeric_limits<float>::infinity();
  const int64_t n = count;
  if (n == 0) return {mn, mx};  // the arrays may be empty: no pointer arithmetic on them
  if (c == kSpeedC) {
    const float* v = f.velocities.data();
#pragma omp parallel for reduction(min : mn) reduction(max : mx) schedule(static)
    for (int64_t k = 0; k < n; ++k) {
      const size_t i = 3 * size_t(k) * stride;
      const double x = v[i], y = v[i + 1], z = v[i + 2];
      out[k] = float(std::sqrt(x * x + y * y + z * z));
      mn = std::min(mn, out[k]);
      mx = std::max(mx, out[k]);
    }
    return {mn, mx};
  }
  if (c >= kVelX && c <= kVelZ && octahedral) {
    const float* v = f.velocities.data();
    const int slot = c - kVelX;
#pragma omp parallel for reduction(min : mn) reduction(max : mx) schedule(static)
    for (int64_t k = 0; k < n; ++k) {
      const size_t i = 3 * size_t(k) * stride;
      out[k] = float(ToOctahedral(v[i], v[i + 1], v[i + 2])[slot]);
      mn = std::min(mn, out[k]);
      mx = std::max(mx, out[k]);
    }
    return {mn, mx};
  }
  const float* src = c <= kPosZ       ? f.positions.data() + c
                     : c == kDensityC ? f.densities.data()
                                      : f.velocities.data() + (c - kVelX);
  const size_t step = (c == kDensityC ? 1 : 3) * size_t(stride);
#pragma omp parallel for reduction(min : mn) reduction(max : mx) schedule(static)
  for (int64_t k = 0; k < n; ++k) {
    out[k] = src[size_t(k) * step];
    mn = std::min(mn, out[k]);
    mx = std::max(mx, out[k]);
  }
  return {mn, mx};
}

// Residuals of a delta frame, zig-zag mapped: cur[k] minus the prediction from the history
// (FORMAT.md); loops specialised by the prediction order.
void DeltaResiduals(const uint32_t* cur, const History& history, Component c, uint32_t first,
                    uint32_t m, uint32_t levels, uint32_t* z) {
  const uint32_t* a = history[0][c].data() + first;
  if (history.size() == 1) {
    for (uint32_t k = 0; k < m; ++k) z[k] = ZigZag(int32_t(int64_t(cur[k]) - a[k]));
    return;
  }
  const uint32_t* b = history[1][c].data() + first;
  const int64_t top = levels;
  if (history.size() == 2) {
    for (uint32_t k = 0; k < m; ++k) {
      const int64_t pred = std::clamp<int64_t>(2 * int64_t(a[k]) - b[k], 0, top);
      z[k] = ZigZag(int32_t(int64_t(cur[k]) - pred));
    }
    return;
  }
  const uint32_t* c3 = history[2][c].data() + first;
  for (uint32_t k = 0; k < m; ++k) {
    const int64_t pred = std::clamp<int64_t>(3 * (int64_t(a[k]) - b[k]) + c3[k], 0, top);
    z[k] = ZigZag(int32_t(int64_t(cur[k]) - pred));
  }
}

// The inverse: values from zig-zag residuals. False if a value leaves [0, levels].
bool UndoDeltaResiduals(const uint32_t* z, const History& history, Component c, uint32_t first,
                        uint32_t m, uint32_t levels, uint32_t* cur) {
  const uint32_t* a = history[0][c].data() + first;
  const uint32_t* b = history.size() > 1 ? history[1][c].data() + first : a;
  const uint32_t* c3 = history.size() > 2 ? history[2][c].data() + first : a;
  const int64_t top = levels;
  const size_t order = history.size();
  bool ok = true;
  for (uint32_t k = 0; k < m; ++k) {
    int64_t pred = a[k];
    if (order == 2) pred = std::clamp<int64_t>(2 * int64_t(a[k]) - b[k], 0, top);
    if (order == 3) pred = std::clamp<int64_t>(3 * (int64_t(a[k]) - b[k]) + c3[k], 0, top);
    const int64_t value = pred + UnZigZag(z[k]);
    ok &= value >= 0 && value <= top;
    cur[k] = uint32_t(value);
  }
  return ok;
}

struct ZstdCCtxDeleter {
  void operator()(ZSTD_CCtx* c) const { ZSTD_freeCCtx(c); }
};
struct ZstdDCtxDeleter {
  void operator()(ZSTD_DCtx* c) const { ZSTD_freeDCtx(c); }
};

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

std::vector<Chunk> FrameEncoder::Encode(const FrameInput& f) {
  const size_t ids = f.positions.size() / 3;
  if (f.positions.size() != 3 * ids) throw std::invalid_argument("positions: size not 3 * count");
  if ((config_.fields & (kSpeed | kVelocity)) && f.velocities.size() != 3 * ids) {
    throw std::invalid_argument("velocities: 3 * count values needed for speed or velocity");
  }
  if ((config_.fields & kDensity) && f.densities.size() != ids) {
    throw std::invalid_argument("densities: count values needed for density");
  }
  if (ids > kMaxCount) throw std::invalid_argument("count over the limit of 20,000,000 particles");
  const uint32_t stride = config_.stride;
  const uint32_t count = uint32_t((ids + stride - 1) / stride);
  const uint32_t per_chunk = config_.chunk_particles;
  const uint32_t chunk_count = std::max<uint32_t>(1, (count + per_chunk - 1) / per_chunk);
  if (chunk_count > 0xFFFF)
    throw std::invalid_argument("chunk_particles too small: > 65535 chunks");

  Header h;
  h.fields = config_.fields;
  h.position_bits = uint8_t(config_.position_bits);
  h.speed_bits = (h.fields & kSpeed) ? uint8_t(config_.speed_bits) : 0;
  h.velocity_bits = (h.fields & kVelocity) ? uint8_t(config_.velocity_bits) : 0;
  h.density_bits = (h.fields & kDensity) ? uint8_t(config_.density_bits) : 0;
  const bool octahedral =
      (h.fields & kVelocity) && config_.velocity_encoding == VelocityEncoding::kOctahedral;
  if (octahedral) {
    h.version = 2;
    h.flags = kOctahedralFlag;  // before the ranges are read from the header
  }
  std::vector<Component> comps;
  for (int c = 0; c < kComponents; ++c) {
    if (h.Has(Component(c))) comps.push_back(Component(c));
  }

  // Gather each component and its extremes (min and max are exact, so the result does not
  // depend on the thread count).
  std::array<double, kComponents> lo, hi;
  std::vector<std::vector<float>>& values = values_;
  values.resize(kComponents);
  for (Component c : comps) {
    values[c].resize(count);
    const auto [mn, mx] = GatherComponent(f, c, stride, count, octahedral, values[c].data());
    lo[c] = mn;
    hi[c] = mx;
  }
  bool keyframe = keyframe_requested_ || frame_seq_ == 0 || count != count_ ||
                  frames_since_keyframe_ >= uint32_t(config_.keyframe_interval);
  for (Component c : comps) keyframe |= count > 0 && (lo[c] < lo_[c] || hi[c] > hi_[c]);
  if (keyframe) {
    // New ranges, with headroom where values move (so later delta frames stay inside). An
    // empty frame has no extremes: any valid range will do.
    if (count == 0) lo.fill(0), hi.fill(1);
    for (Component c : comps) {
      double a = lo[c], b = hi[c];
      if (c <= kPosZ) {
        // The domain when particles are inside it (walls keep them there); with headroom
        // where they are not.
        const bool has_domain = f.domain_max[c] > f.domain_min[c];
        const bool inside = has_domain && a >= f.domain_min[c] && b <= f.domain_max[c];
        const double margin = inside ? 0.0 : 0.05 * (b - a) + 1e-3;
        a = (has_domain ? std::min(a, f.domain_min[c]) : a) - margin;
        b = (has_domain ? std::max(b, f.domain_max[c]) : b) + margin;
      } else if (c == kSpeedC) {
        a = 0;
        b = std::max(1.25 * b, 1e-3);
      } else if (c == kDensityC) {
        const double margin = 0.1 * (b - a) + std::max(1e-3, 1e-3 * std::abs(b));
        a -= margin;
        b += margin;
      } else if (octahedral) {
        // |v| like speed; the octahedral coordinates always lie in [-1, 1].
        a = c == kVelX ? 0.0 : -1.0;
        b = c == kVelX ? std::max(1.25 * b, 1e-3) : 1.0;
      } else {
        // One range for the three components (the header has one velocity_max).
        b = 1e-3;
        for (int v = kVelX; v <= kVelZ; ++v) {
          b = std::max({b, 1.25 * std::abs(lo[v]), 1.25 * std::abs(hi[v])});
        }
        a = -b;
      }
      lo_[c] = a;
      hi_[c] = b;
    }
  }
  for (int a = 0; a < 3; ++a) h.position_min[a] = lo_[a], h.position_max[a] = hi_[a];
  if (h.fields & kSpeed) h.speed_max = hi_[kSpeedC];
  if (h.fields & kVelocity) h.velocity_max = hi_[kVelX];
  if (h.fields & kDensity) h.density_min = lo_[kDensityC], h.density_max = hi_[kDensityC];

  // Quantise. The same values are what the decoder will hold, so prediction never drifts.
  std::array<bool, 8> present{};
  for (Component c : comps) present[c] = true;
  Values q = TakeValues(spare_, count, present);
  for (Component c : comps) {
    const uint32_t levels = Levels(h.Bits(c));
    const double a = h.Lo(c), b = h.Hi(c);
    const float* v = values[c].data();
    uint32_t* out = q[c].data();
    const double scale = double(levels) / (b - a);
#pragma omp parallel for schedule(static)
    for (int64_t k = 0; k < int64_t(count); ++k) out[k] = Quantize(v[k], a, scale, levels);
  }

  h.flags |= keyframe ? kKeyframeFlag : 0;
  h.frame_seq = frame_seq_;
  h.count = count;
  h.step = f.step;
  h.time = f.time;
  h.stride = stride;
  h.chunk_count = uint16_t(chunk_count);
  std::vector<Chunk> chunks(chunk_count);
  std::vector<size_t> zstd_errors(chunk_count, 0);  // no exceptions inside the parallel loop
#pragma omp parallel for schedule(dynamic, 1)
  for (int64_t ci = 0; ci < int64_t(chunk_count); ++ci) {
    Header ch = h;
    ch.chunk_index = uint16_t(ci);
    ch.first = uint32_t(ci) * per_chunk;
    const uint32_t m = std::min(per_chunk, count - std::min(count, ch.first));
    ch.chunk_particles = m;
    // Residuals, zig-zag mapped, per component; then split into byte planes of the high parts
    // (compressed) and packed low bits (stored).
    // Per-thread scratch, kept between calls.
    thread_local std::vector<uint32_t> z;
    thread_local std::vector<uint8_t> raw, low_bits;
    z.resize(size_t(m) * comps.size());
    raw.assign(2 * comps.size(), 0);
    raw.reserve(2 * comps.size() + 4 * size_t(m) * comps.size());
    low_bits.clear();
    for (size_t slot = 0; slot < comps.size(); ++slot) {
      const Component c = comps[slot];
      const uint32_t levels = Levels(h.Bits(c));
      const uint32_t* cur = q[c].data() + ch.first;
      uint32_t* out = z.data() + slot * m;
      if (keyframe) {
        for (uint32_t k = 0; k < m; ++k) {
          out[k] = ZigZag(int32_t(int64_t(cur[k]) - (k == 0 ? 0 : int64_t(cur[k - 1]))));
        }
      } else {
        DeltaResiduals(cur, history_, c, ch.first, m, levels, out);
      }
      uint64_t sum_z = 0;
      for (uint32_t k = 0; k < m; ++k) sum_z += out[k];
      const int split = SplitBitsFor(sum_z, m);
      uint32_t max_high = 0;
      for (uint32_t k = 0; k < m; ++k) max_high = std::max(max_high, out[k] >> split);
      raw[2 * slot] = uint8_t(split);
      raw[2 * slot + 1] = uint8_t(PlanesFor(max_high));
      PackBits(out, m, split, low_bits);
    }
    for (size_t slot = 0; slot < comps.size(); ++slot) {
      const uint32_t* zs = z.data() + slot * m;
      const int split = raw[2 * slot];
      for (int p = 0; p < raw[2 * slot + 1]; ++p) {
        const size_t at = raw.size();
        raw.resize(at + m);
        uint8_t* plane = raw.data() + at;
        const int shift = split + 8 * p;
        for (uint32_t k = 0; k < m; ++k) plane[k] = uint8_t(zs[k] >> shift);
      }
    }
    thread_local std::unique_ptr<ZSTD_CCtx, ZstdCCtxDeleter> cctx(ZSTD_createCCtx());
    thread_local std::vector<uint8_t> compressed;
    compressed.resize(std::max(compressed.size(), ZSTD_compressBound(raw.size())));
    const size_t payload = ZSTD_compressCCtx(cctx.get(), compressed.data(), compressed.size(),
                                             raw.data(), raw.size(), config_.zstd_level);
    if (ZSTD_isError(payload)) {
      zstd_errors[ci] = payload;
      continue;
    }
    ch.raw_size = uint32_t(raw.size());
    ch.payload_size = uint32_t(payload);
    ch.bits_size = uint32_t(low_bits.size());
    Chunk& chunk = chunks[ci];
    chunk.reserve(kHeaderSize + payload + low_bits.size());
    chunk.resize(kHeaderSize);
    chunk.insert(chunk.end(), compressed.begin(), compressed.begin() + payload);
    chunk.insert(chunk.end(), low_bits.begin(), low_bits.end());
    WriteHeader(ch, chunk.data());
  }
  for (size_t e : zstd_errors) {
    if (e != 0) throw std::runtime_error(std::string("zstd: ") + ZSTD_getErrorName(e));
  }

  PushHistory(history_, std::move(q), keyframe, spare_);
  frames_since_keyframe_ = keyframe ? 1 : frames_since_keyframe_ + 1;
  keyframe_requested_ = false;
  last_was_keyframe_ = keyframe;
  count_ = count;
  ++frame_seq_;
  return chunks;
}

namespace {

// Decodes one chunk's payload into `q` (quantised values, per component, frame-sized) and the
// frame's float arrays. Chunks of a frame write disjoint ranges, so they run in parallel. Returns
// an error message, empty on success (no exceptions inside parallel loops).
std::string DecodeBody(const Header& h, std::span<const uint8_t> payload,
                       std::span<const uint8_t> bits, std::vector<std::vector<uint32_t>>& q,
                       const History& history, Frame& frame) {
  const int n = ComponentCount(h);
  const uint32_t m = h.chunk_particles;
  const unsigned long long content = ZSTD_getFrameContentSize(payload.data(), payload.size());
  if (content != h.raw_size) return "payload size does not match the header";
  // At most two bytes and 4 planes per component.
  if (h.raw_size > uint64_t(n) * (2 + 4 * uint64_t(m))) return "raw size too large";
  thread_local std::unique_ptr<ZSTD_DCtx, ZstdDCtxDeleter> dctx(ZSTD_createDCtx());
  thread_local std::vector<uint8_t> raw;
  raw.resize(h.raw_size);
  const size_t got =
      ZSTD_decompressDCtx(dctx.get(), raw.data(), raw.size(), payload.data(), payload.size());
  if (ZSTD_isError(got) || got != raw.size()) return "payload does not decompress";
  if (raw.size() < 2 * size_t(n)) return "payload too short";
  size_t expected = 2 * size_t(n);
  size_t expected_bits = 0;
  for (int s = 0; s < n; ++s) {
    if (raw[2 * s] > 24) return "split beyond 24 bits";
    if (raw[2 * s + 1] > 4) return "more than 4 byte planes";
    expected += size_t(raw[2 * s + 1]) * m;
    expected_bits += PackedBytes(m, raw[2 * s]);
  }
  if (expected != raw.size()) return "payload size does not match its byte planes";
  if (expected_bits != bits.size()) return "packed bits do not match their split";

  size_t at = 2 * size_t(n);
  size_t bit_at = 0;  // byte offset of the component's packed bits
  thread_local std::vector<uint32_t> z;
  z.resize(m);
  int slot = 0;
  for (int ci = 0; ci < kComponents; ++ci) {
    const auto c = Component(ci);
    if (!h.Has(c)) continue;
    const int split = raw[2 * slot];
    const int planes = raw[2 * slot + 1];
    ++slot;
    const uint32_t levels = Levels(h.Bits(c));
    uint32_t* cur = q[c].data() + h.first;
    // z = (high << split) | low, high from the byte planes, low from the packed bits.
    if (split + 8 * planes > 32) return "residual wider than 32 bits";
    if (planes == 0) std::fill(z.begin(), z.end(), 0u);
    for (int p = 0; p < planes; ++p) {
      const uint8_t* plane = raw.data() + at + size_t(p) * m;
      const int shift = split + 8 * p;
      if (p == 0) {
        for (uint32_t k = 0; k < m; ++k) z[k] = uint32_t(plane[k]) << shift;
      } else {
        for (uint32_t k = 0; k < m; ++k) z[k] |= uint32_t(plane[k]) << shift;
      }
    }
    if (split > 0) {
      const uint8_t* packed = bits.data() + bit_at;
      const uint64_t mask = (uint64_t{1} << split) - 1;
      uint64_t acc = 0;
      int filled = 0;
      for (uint32_t k = 0; k < m; ++k) {
        while (filled < split) {
          acc |= uint64_t(*packed++) << filled;
          filled += 8;
        }
        z[k] |= uint32_t(acc & mask);
        acc >>= split;
        filled -= split;
      }
    }
    bool in_range = true;
    if (h.keyframe()) {
      int64_t value = 0;
      for (uint32_t k = 0; k < m && in_range; ++k) {
        value += UnZigZag(z[k]);
        in_range = value >= 0 && value <= int64_t(levels);
        cur[k] = uint32_t(value);
      }
    } else {
      in_range = UndoDeltaResiduals(z.data(), history, c, h.first, m, levels, cur);
    }
    if (!in_range) return "decoded value outside its range";
    at += size_t(planes) * m;
    bit_at += PackedBytes(m, split);

    if (m == 0) continue;  // an empty frame: its arrays may be empty
    if (h.octahedral() && c >= kVelX && c <= kVelZ) continue;  // needs all three: below
    const double lo = h.Lo(c);
    const double step = (h.Hi(c) - lo) / double(levels);
    float* out = c <= kPosZ       ? frame.positions.data() + 3 * size_t(h.first) + c
                 : c == kSpeedC   ? frame.speed.data() + h.first
                 : c == kDensityC ? frame.densities.data() + h.first
                                  : frame.velocities.data() + 3 * size_t(h.first) + (c - kVelX);
    const size_t out_stride = (c <= kPosZ || (c >= kVelX && c <= kVelZ)) ? 3 : 1;
    for (uint32_t k = 0; k < m; ++k) out[k * out_stride] = Dequantize(cur[k], lo, step);
  }
  if (h.octahedral() && m > 0) {
    const uint32_t levels = Levels(h.velocity_bits);
    const double magnitude_step = h.velocity_max / double(levels);
    const double coordinate_step = 2.0 / double(levels);
    const uint32_t* qm = q[kVelX].data() + h.first;
    const uint32_t* qu = q[kVelY].data() + h.first;
    const uint32_t* qv = q[kVelZ].data() + h.first;
    float* out = frame.velocities.data() + 3 * size_t(h.first);
    for (uint32_t k = 0; k < m; ++k) {
      FromOctahedral(0.0 + double(qm[k]) * magnitude_step, -1.0 + double(qu[k]) * coordinate_step,
                     -1.0 + double(qv[k]) * coordinate_step, out + 3 * size_t(k));
    }
  }
  return {};
}

// The encoder's layout: chunk i covers particles [i P, min((i + 1) P, count)) for one chunk
// size P per frame. Checking every chunk against it (P is learnt from the first chunk that
// shows it) means the chunks of a frame cover it exactly once: no particle is left undecoded
// and no two chunks write the same values.
void CheckChunkRange(const Header& h, uint32_t& chunk_size) {
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

// Half a quantisation step plus float rounding: of the decoded value, and of the speed, which is
// rounded to float before it is quantised (half a float ulp of the range's magnitude each).
double ErrorBound(double lo, double hi, int bits) {
  const double half_step = 0.5 * (hi - lo) / double(Levels(bits));
  const double magnitude = std::max(std::abs(lo), std::abs(hi));
  return half_step + magnitude * std::numeric_limits<float>::epsilon();
}

// The bound on each component of an octahedral velocity, from |v1 - v0| <= |m1 - m0| +
// m0 |n1 - n0| with m the magnitude and n the direction. The magnitude is off by at most half a
// step, velocity_max / (2 L). Each coordinate is off by at most half its step, 1 / L, so (u, v)
// moves by at most sqrt(2) / L; the octahedron point p(u, v) is piecewise linear with gradient
// norm at most sqrt(3), and |p| >= 1 / sqrt(3) because |p|_1 = 1; with
// |a / |a| - b / |b|| <= 2 |a - b| / |a| the direction moves by at most
// 2 sqrt(3) sqrt(3) sqrt(2) / L = 6 sqrt(2) / L. Float rounding of the gathered values and of
// the result adds a few float epsilons of velocity_max.
double OctahedralErrorBound(double velocity_max, int bits) {
  const double levels = double(Levels(bits));
  return velocity_max *
         ((0.5 + 6.0 * std::sqrt(2.0)) / levels + 8 * std::numeric_limits<float>::epsilon());
}

}  // namespace

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
  std::vector<Header> headers;
  headers.reserve(chunks.size());
  for (const Chunk& chunk : chunks) headers.push_back(ReadHeader(chunk));
  bool done = false;
  // Chunks are taken in order; each group of consecutive chunks of one frame decodes in
  // parallel. A frame left incomplete when the next one starts is dropped.
  size_t begin = 0;
  while (begin < chunks.size()) {
    const Header& h = headers[begin];
    if (!pending_seq_ || *pending_seq_ != h.frame_seq) {
      if (pending_seq_) have_previous_ = false;  // the incomplete frame is lost
      pending_seq_.reset();
      if (!h.keyframe()) {
        Header previous;
        bool reference_ok = have_previous_;
        if (reference_ok) {
          previous = ReadHeader(previous_header_);
          reference_ok = previous.frame_seq + 1 == h.frame_seq && previous.SameLayout(h);
        }
        if (!reference_ok) {
          have_previous_ = false;  // wait for a keyframe
          ++begin;
          continue;
        }
      }
      pending_seq_ = h.frame_seq;
      pending_header_.assign(chunks[begin].begin(), chunks[begin].begin() + kHeaderSize);
      Put<uint32_t>(pending_header_.data() + 140, 0);  // a header alone: no payload
      Put<uint32_t>(pending_header_.data() + 144, 0);
      received_.assign(h.chunk_count, false);
      chunk_size_ = 0;
      pending_.frame_seq = h.frame_seq;
      pending_.step = h.step;
      pending_.time = h.time;
      pending_.keyframe = h.keyframe();
      pending_.count = h.count;
      pending_.stride = h.stride;
      pending_.fields = h.fields;
      pending_.velocity_encoding =
          h.octahedral() ? VelocityEncoding::kOctahedral : VelocityEncoding::kComponents;
      // Sized without zeroing when the size is unchanged: every value is overwritten.
      pending_.positions.resize(3 * size_t(h.count));
      pending_.speed.resize((h.fields & kSpeed) ? h.count : 0);
      pending_.velocities.resize((h.fields & kVelocity) ? 3 * size_t(h.count) : 0);
      pending_.densities.resize((h.fields & kDensity) ? h.count : 0);
      pending_.speed_error = pending_.velocity_error = pending_.density_error = 0;
      std::array<bool, 8> present{};
      for (int c = 0; c < kComponents; ++c) present[c] = h.Has(Component(c));
      if (!current_.empty()) spare_.push_back(std::move(current_));
      current_ = TakeValues(spare_, h.count, present);
    }
    const Header first = ReadHeader(pending_header_);
    size_t end = begin;
    // Check the whole group before marking anything received, so a bad chunk leaves the
    // pending frame as it was.
    std::vector<uint16_t> group;
    while (end < chunks.size() && headers[end].frame_seq == first.frame_seq) {
      const Header& hc = headers[end];
      CheckChunkRange(hc, chunk_size_);
      if (hc.flags != first.flags || hc.count != first.count || hc.step != first.step ||
          hc.chunk_count != first.chunk_count || !hc.SameLayout(first) ||
          !(hc.time == first.time)) {
        throw DecodeError("chunk " + std::to_string(hc.chunk_index) +
                          " does not match the other chunks of frame " +
                          std::to_string(hc.frame_seq));
      }
      if (received_[hc.chunk_index] ||
          std::find(group.begin(), group.end(), hc.chunk_index) != group.end()) {
        throw DecodeError("chunk " + std::to_string(hc.chunk_index) + " of frame " +
                          std::to_string(hc.frame_seq) + " received twice");
      }
      group.push_back(hc.chunk_index);
      ++end;
    }
    for (uint16_t index : group) received_[index] = true;
    std::vector<std::string> errors(end - begin);
#pragma omp parallel for schedule(dynamic, 1)
    for (int64_t k = int64_t(begin); k < int64_t(end); ++k) {
      std::span<const uint8_t> payload(chunks[k].data() + kHeaderSize, headers[k].payload_size);
      std::span<const uint8_t> bits(payload.data() + payload.size(), headers[k].bits_size);
      errors[k - begin] = DecodeBody(headers[k], payload, bits, current_, history_, pending_);
    }
    for (size_t k = 0; k < errors.size(); ++k) {
      if (!errors[k].empty()) {
        pending_seq_.reset();
        have_previous_ = false;
        throw DecodeError("corrupt chunk " + std::to_string(headers[begin + k].chunk_index) +
                          " of frame " + std::to_string(first.frame_seq) + ": " + errors[k]);
      }
    }
    begin = end;
    if (std::find(received_.begin(), received_.end(), false) != received_.end()) continue;

    // Complete: it becomes the reference of the next delta frame.
    for (int a = 0; a < 3; ++a) {
      pending_.position_error[a] =
          ErrorBound(first.position_min[a], first.position_max[a], first.position_bits);
    }
    if (first.fields & kSpeed)
      pending_.speed_error = ErrorBound(0, first.speed_max, first.speed_bits);
    if (first.fields & kVelocity) {
      pending_.velocity_error =
          first.octahedral()
              ? OctahedralErrorBound(first.velocity_max, first.velocity_bits)
              : ErrorBound(-first.velocity_max, first.velocity_max, first.velocity_bits);
    }
    if (first.fields & kDensity) {
      pending_.density_error = ErrorBound(first.density_min, first.density_max, first.density_bits);
    }
    PushHistory(history_, std::move(current_), first.keyframe(), spare_);
    current_.clear();
    previous_header_ = pending_header_;
    have_previous_ = true;
    pending_seq_.reset();
    // Hand the frame over and keep the caller's old buffers for the next one.
    std::swap(pending_, out);
    done = true;
  }
  return done;
}

}  // namespace dysa::codec
