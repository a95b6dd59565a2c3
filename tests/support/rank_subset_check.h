// The check the CPU and GPU tests of Simulation::ReadParticlesByIdBelowRank share: a read of a
// level of detail's subset writes exactly the particles the codec's host-side selection keeps
// (codec::KeptIds, the encoder's), with the bits of a full read, and nothing else.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <vector>

#include "dysa/codec/detail_subset.h"
#include "dysa/core/simulation.h"

namespace dysa::testing {

// The particles of a subset read, every entry of the id-indexed arrays (the unwritten ones
// hold the sentinel).
struct SubsetRead {
  size_t written = 0;  // what ReadParticlesByIdBelowRank returned
  std::vector<float> position, velocity, density;
};

inline constexpr float kUnwritten = -1.25e30f;

inline SubsetRead ReadSubset(const Simulation& sim, uint32_t threshold) {
  const size_t n = sim.particle_count();
  SubsetRead r;
  r.position.assign(3 * n, kUnwritten);
  r.velocity.assign(3 * n, kUnwritten);
  r.density.assign(n, kUnwritten);
  r.written = sim.ReadParticlesByIdBelowRank(threshold, {r.position, r.velocity, r.density});
  return r;
}

inline bool SameBits(float a, float b) { return std::memcmp(&a, &b, sizeof(float)) == 0; }

// Reads the subset of `threshold` (> 0) and a full frame of `sim`'s current state: the subset
// holds exactly codec::KeptIds(n, 1, threshold), each with the full frame's bits.
inline void ExpectSubsetIsTheHostSelection(const Simulation& sim, uint32_t threshold) {
  const size_t n = sim.particle_count();
  std::vector<float> position(3 * n), velocity(3 * n), density(n);
  sim.ReadParticlesById({position, velocity, density});
  const SubsetRead subset = ReadSubset(sim, threshold);
  const std::vector<uint32_t> kept = codec::KeptIds(n, 1, threshold);
  ASSERT_EQ(subset.written, kept.size()) << "threshold " << threshold;
  std::vector<bool> keeps(n, false);
  for (uint32_t id : kept) keeps[id] = true;
  for (size_t k = 0; k < n; ++k) {
    for (int a = 0; a < 3; ++a) {
      const size_t e = 3 * k + size_t(a);
      ASSERT_TRUE(SameBits(subset.position[e], keeps[k] ? position[e] : kUnwritten))
          << "position of id " << k << ", threshold " << threshold;
      ASSERT_TRUE(SameBits(subset.velocity[e], keeps[k] ? velocity[e] : kUnwritten))
          << "velocity of id " << k << ", threshold " << threshold;
    }
    ASSERT_TRUE(SameBits(subset.density[k], keeps[k] ? density[k] : kUnwritten))
        << "density of id " << k << ", threshold " << threshold;
  }
}

}  // namespace dysa::testing
