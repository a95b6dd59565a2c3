// Writes the seed corpus of frame_decoder_fuzzer: real streams from FrameEncoder (keyframes and
// delta frames, several configurations), in the fuzzer's input layout (fuzz_input.h).
//
//   make_corpus DIR     writes DIR/<name> for each seed (DIR must exist)
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "dysa/codec/frame_codec.h"
#include "fuzz_input.h"

namespace {

using namespace dysa::codec;
using namespace dysa::fuzz;

// n particles on a jittered lattice in [-3.5, 3.5]^3 (domain [-5, 5]^3) that swirl slowly.
struct Particles {
  explicit Particles(uint32_t count) : n(count) {
    uint64_t s = 12345;
    auto next = [&s] {
      s = s * 6364136223846793005ull + 1442695040888963407ull;
      return double(s >> 11) * 0x1.0p-53;
    };
    const int side = std::max(1, int(std::ceil(std::cbrt(double(count)))));
    base.resize(3 * n);
    for (uint32_t i = 0; i < n; ++i) {
      const int c[3] = {int(i) % side, (int(i) / side) % side, int(i) / (side * side)};
      for (int a = 0; a < 3; ++a) base[3 * i + a] = -3.5 + 7.0 * (c[a] + 0.3 * next()) / side;
    }
  }

  FrameInput Make(int f) {
    positions.resize(3 * n);
    velocities.resize(3 * n);
    densities.resize(n);
    const double t = f / 60.0, w = 0.4;
    for (uint32_t i = 0; i < n; ++i) {
      const double x = base[3 * i], y = base[3 * i + 1], z = base[3 * i + 2];
      const double angle = w * t * (1 + 0.1 * std::sin(y));
      positions[3 * i + 0] = float(x * std::cos(angle) - z * std::sin(angle));
      positions[3 * i + 1] = float(y - 0.1 * t * t);
      positions[3 * i + 2] = float(x * std::sin(angle) + z * std::cos(angle));
      velocities[3 * i + 0] = float(-w * positions[3 * i + 2]);
      velocities[3 * i + 1] = float(-0.2 * t);
      velocities[3 * i + 2] = float(w * positions[3 * i + 0]);
      densities[i] = float(630 + 40 * std::sin(x + t) * std::cos(z));
    }
    FrameInput in;
    in.step = uint64_t(f) * 10;
    in.time = t;
    in.domain_min = {-5, -5, -5};
    in.domain_max = {5, 5, 5};
    in.positions = positions;
    in.velocities = velocities;
    in.densities = densities;
    return in;
  }

  uint32_t n;
  std::vector<double> base;
  std::vector<float> positions, velocities, densities;
};

// Encodes `frames` frames; `tweak(f, particles)` may change a frame's data before encoding.
std::vector<std::vector<Chunk>> Encode(
    const StreamConfig& config, uint32_t n, int frames,
    const std::function<void(int, Particles&, FrameInput&)>& tweak = {}) {
  FrameEncoder encoder(config);
  Particles p(n);
  std::vector<std::vector<Chunk>> out;
  for (int f = 0; f < frames; ++f) {
    FrameInput in = p.Make(f);
    if (tweak) tweak(f, p, in);
    out.push_back(encoder.Encode(in));
  }
  return out;
}

std::vector<uint8_t> Seed(uint8_t mode, const std::vector<Chunk>& chunks, Split split) {
  std::vector<uint8_t> out{mode};
  for (const Chunk& c : chunks) {
    if (split == kLengthPrefixed)
      AppendLengthPrefixed(out, c);
    else
      out.insert(out.end(), c.begin(), c.end());
  }
  return out;
}

std::vector<Chunk> Flatten(const std::vector<std::vector<Chunk>>& frames) {
  std::vector<Chunk> all;
  for (const auto& f : frames) all.insert(all.end(), f.begin(), f.end());
  return all;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_corpus DIR\n");
    return 2;
  }
  const std::string dir = argv[1];
  size_t total = 0;
  auto write = [&](const std::string& name, const std::vector<uint8_t>& bytes) {
    std::ofstream(dir + "/" + name, std::ios::binary)
        .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    total += bytes.size();
    std::printf("%-28s %6zu bytes\n", name.c_str(), bytes.size());
  };

  // Defaults (positions + speed, 16/8 bits): a keyframe, then delta frames (the third and
  // fourth extrapolate from the last two).
  const auto defaults = Flatten(Encode(StreamConfig{}, 64, 4));
  write("defaults_per_chunk",
        Seed(ModeByte(kPerChunk, kLengthPrefixed), defaults, kLengthPrefixed));
  write("defaults_at_magic", Seed(ModeByte(kPerChunk, kAtMagic), defaults, kAtMagic));
  write("defaults_recycled",
        Seed(ModeByte(kPerChunk, kLengthPrefixed, 1, true), defaults, kLengthPrefixed));

  // All fields, stride 3, 8 particles per chunk: 34 particles in 5 chunks per frame.
  StreamConfig all;
  all.fields = kPositions | kSpeed | kVelocity | kDensity;
  all.stride = 3;
  all.chunk_particles = 8;
  const auto all_frames = Encode(all, 100, 3);
  write("all_fields_stride_batch",
        Seed(ModeByte(kAllAtOnce, kLengthPrefixed), Flatten(all_frames), kLengthPrefixed));
  write("all_fields_stride_diff",
        Seed(ModeByte(kDifferential, kLengthPrefixed), Flatten(all_frames), kLengthPrefixed));

  // The same stream with chunks out of order and one chunk of frame 1 lost: frame 1 is dropped
  // when frame 2 starts and frame 2 waits for a keyframe.
  {
    std::vector<Chunk> chunks;
    for (size_t f = 0; f < all_frames.size(); ++f) {
      const auto& c = all_frames[f];
      for (size_t k = c.size(); k-- > 0;) {
        if (f == 1 && k == 2) continue;
        chunks.push_back(c[k]);
      }
    }
    write("all_fields_lost_chunk",
          Seed(ModeByte(kGroups, kLengthPrefixed, 3), chunks, kLengthPrefixed));
  }

  // 8-bit positions with density, a keyframe every 2 frames, 16 particles per chunk.
  StreamConfig small;
  small.fields = kPositions | kDensity;
  small.position_bits = 8;
  small.density_bits = 10;
  small.keyframe_interval = 2;
  small.chunk_particles = 16;
  const auto small_frames = Flatten(Encode(small, 48, 4));
  write("pos8_density_groups",
        Seed(ModeByte(kGroups, kLengthPrefixed, 2), small_frames, kLengthPrefixed));
  write("pos8_density_diff",
        Seed(ModeByte(kDifferential, kLengthPrefixed), small_frames, kLengthPrefixed));

  // 24-bit positions and 16-bit velocity; in frame 2 a particle leaves the domain and the
  // velocity range, which forces a keyframe with new ranges.
  StreamConfig wide;
  wide.fields = kPositions | kVelocity;
  wide.position_bits = 24;
  wide.velocity_bits = 16;
  wide.chunk_particles = 1000;
  const auto wide_frames = Encode(wide, 32, 4, [](int f, Particles& p, FrameInput&) {
    if (f >= 2) {
      p.positions[0] = 7.5f;
      p.velocities[4] = 30.0f;
    }
  });
  write("pos24_velocity_range_exit",
        Seed(ModeByte(kDifferential, kLengthPrefixed), Flatten(wide_frames), kLengthPrefixed));

  // Octahedral velocity (format version 2) with speed; keyframe, then delta frames.
  StreamConfig octahedral;
  octahedral.fields = kPositions | kSpeed | kVelocity;
  octahedral.velocity_encoding = dysa::codec::VelocityEncoding::kOctahedral;
  octahedral.velocity_bits = 10;
  octahedral.chunk_particles = 24;
  write("octahedral_velocity_diff", Seed(ModeByte(kDifferential, kLengthPrefixed),
                                         Flatten(Encode(octahedral, 40, 4)), kLengthPrefixed));

  // Empty frames (count 0), then a non-empty keyframe.
  {
    FrameEncoder encoder(StreamConfig{});
    // Empty spans with a non-null data pointer: FrameEncoder::Encode offsets the data pointer
    // of each array even when it is empty, which is UB on a null pointer (UBSan stops there).
    static const float kNone[1] = {};
    FrameInput empty;
    empty.positions = std::span<const float>(kNone, 0);
    empty.velocities = std::span<const float>(kNone, 0);
    std::vector<Chunk> chunks;
    for (int f = 0; f < 2; ++f) {
      for (auto& c : encoder.Encode(empty)) chunks.push_back(c);
    }
    Particles p(5);
    for (auto& c : encoder.Encode(p.Make(0))) chunks.push_back(c);
    write("empty_frames", Seed(ModeByte(kPerChunk, kLengthPrefixed), chunks, kLengthPrefixed));
  }

  std::printf("total %zu bytes\n", total);
  return 0;
}
