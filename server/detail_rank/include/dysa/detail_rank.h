// The level of detail's rank of a particle id, one definition for the host and the GPU.
//
// Every particle id has a fixed pseudo-random rank in [0, 2^32): the upper 32 bits of
// splitmix64(id) (Steele, Lea and Flood 2014, "Fast splittable pseudorandom number generators").
// A detail threshold T keeps the particles whose rank is below T (dysa/codec/detail_subset.h
// says why: a stable, nested, spatially even subset). Integer arithmetic only, so the codec's
// host code and the core's CUDA kernels (compiled by nvcc, where these functions are
// __host__ __device__) choose the same particles bit for bit.
#pragma once

#include <cstdint>

#if defined(__CUDACC__)
#define DYSA_HOST_DEVICE __host__ __device__
#else
#define DYSA_HOST_DEVICE
#endif

namespace dysa {

// splitmix64's output function (its finaliser applied to x + golden gamma).
DYSA_HOST_DEVICE constexpr uint64_t SplitMix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// The particle's rank, uniform over [0, 2^32).
DYSA_HOST_DEVICE constexpr uint32_t DetailRank(uint32_t id) {
  return uint32_t(SplitMix64(id) >> 32);
}

// Whether the particle's rank is below `threshold`: strictly, so threshold 0 keeps no particle
// (the codec's "0: no selection" is DetailKeeps's, not this function's).
DYSA_HOST_DEVICE constexpr bool BelowRank(uint32_t id, uint32_t threshold) {
  return DetailRank(id) < threshold;
}

}  // namespace dysa
