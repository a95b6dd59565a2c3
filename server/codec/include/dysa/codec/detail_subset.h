// Level of detail by rank: a stable, nested, spatially even subset of the particles.
//
// Every particle id has a fixed pseudo-random rank in [0, 2^32): the upper 32 bits of
// splitmix64(id) (Steele, Lea and Flood 2014, "Fast splittable pseudorandom number generators").
// A frame of detail threshold T holds the particles whose rank is below T, i.e. a fraction
// T / 2^32 of them. The subset is
// - stable: the same particles in every frame while T holds (so delta coding still pays and
//   nothing flickers);
// - nested: a larger T adds particles and never drops one;
// - spatially even: the rank does not depend on where a particle is, so the kept particles are
//   a uniform random sample of the fluid whatever the mixing (unlike "every n-th id", which
//   follows the spawn order).
// T = 0 means no selection (every particle, or every stride-th with a stride).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "dysa/detail_rank.h"

namespace dysa::codec {

// splitmix64's output function and the particle's rank, uniform over [0, 2^32): one definition
// for the host and the GPU (dysa/detail_rank.h).
using ::dysa::DetailRank;
using ::dysa::SplitMix64;

// The threshold that keeps `fraction` of the particles: 0 (all) for a fraction >= 1, at least
// 1 for any fraction > 0. Throws std::invalid_argument unless 0 < fraction (finite).
uint32_t DetailThreshold(double fraction);
// The fraction a threshold keeps: threshold / 2^32, or 1 for 0.
double DetailFraction(uint32_t threshold);

// Whether particle `id` is in the frame of this stride and threshold.
constexpr bool DetailKeeps(uint32_t id, uint32_t stride, uint32_t threshold) {
  return id % stride == 0 && (threshold == 0 || BelowRank(id, threshold));
}

// The ids 0 .. ids - 1 a frame of this stride and threshold keeps, increasing (the encoder's
// selection).
std::vector<uint32_t> KeptIds(size_t ids, uint32_t stride, uint32_t threshold);

// The decoder's side: the first `count` ids kept (which are the frame's particles, as a frame's
// ids are all below its total particle count). Returns false when fewer than `count` ids below
// `limit` qualify (a corrupt header). `out` is resized to `count`.
bool FirstKeptIds(uint32_t count, uint32_t stride, uint32_t threshold, uint32_t limit,
                  std::vector<uint32_t>& out);

}  // namespace dysa::codec
