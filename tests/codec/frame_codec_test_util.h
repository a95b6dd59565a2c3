// Synthetic particle frames for the codec tests and the cross-language vectors.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "dysa/codec/frame_codec.h"

namespace dysa::codec::testing {

// A block of particles on a jittered lattice in [-3.5, 3.5]^3, inside the [-5, 5]^3 domain as it
// turns, that moves smoothly with time, so consecutive frames are like a simulation's: positions,
// velocities and densities change a bit.
struct SyntheticFrames {
  explicit SyntheticFrames(uint32_t count, uint64_t seed = 1) : n(count), base(3 * count) {
    uint64_t s = seed;
    auto next = [&s] {
      s = s * 6364136223846793005ull + 1442695040888963407ull;
      return double(s >> 11) * 0x1.0p-53;
    };
    const int side = int(std::ceil(std::cbrt(double(count))));
    for (uint32_t i = 0; i < count; ++i) {
      const int x = int(i) % side, y = (int(i) / side) % side, z = int(i) / (side * side);
      base[3 * i + 0] = -3.5 + 7.0 * (x + 0.3 * next()) / side;
      base[3 * i + 1] = -3.5 + 7.0 * (y + 0.3 * next()) / side;
      base[3 * i + 2] = -3.5 + 7.0 * (z + 0.3 * next()) / side;
    }
  }

  // Frame `f` of the sequence: a swirl of speed up to ~2 m/s, 1/60 s apart.
  void Make(int f, std::vector<float>& positions, std::vector<float>& velocities,
            std::vector<float>& densities) const {
    positions.resize(3 * n);
    velocities.resize(3 * n);
    densities.resize(n);
    const double t = f / 60.0;
    for (uint32_t i = 0; i < n; ++i) {
      const double x = base[3 * i], y = base[3 * i + 1], z = base[3 * i + 2];
      const double w = 0.4;
      const double angle = w * t * (1 + 0.1 * std::sin(y));
      positions[3 * i + 0] = float(x * std::cos(angle) - z * std::sin(angle));
      positions[3 * i + 1] = float(y - 0.5 * t * t * 0.2);
      positions[3 * i + 2] = float(x * std::sin(angle) + z * std::cos(angle));
      velocities[3 * i + 0] = float(-w * positions[3 * i + 2]);
      velocities[3 * i + 1] = float(-0.2 * t);
      velocities[3 * i + 2] = float(w * positions[3 * i + 0]);
      densities[i] = float(630 + 40 * std::sin(x + t) * std::cos(z));
    }
  }

  uint32_t n;
  std::vector<double> base;
};

inline FrameInput Input(const std::vector<float>& positions, const std::vector<float>& velocities,
                        const std::vector<float>& densities, uint64_t step, double time) {
  FrameInput in;
  in.step = step;
  in.time = time;
  in.domain_min = {-5, -5, -5};
  in.domain_max = {5, 5, 5};
  in.positions = positions;
  in.velocities = velocities;
  in.densities = densities;
  return in;
}

}  // namespace dysa::codec::testing
