// A level of detail's subset as a GPU backend hands it to the host: the particles of
// BelowRank(id, threshold) (dysa/detail_rank.h), in id order, chosen and packed on the device so
// that only they cross to the host (cuda/rank_subset.cuh). Plain C++: Simulation scatters it.
#pragma once

#include <cstddef>
#include <cstdint>

namespace dysa {

// Host memory the backend owns, valid until its next read of a subset: `count` particles, entry
// j of each array particle ids[j]'s; an array not asked for is null. (Pointers, not spans: the
// CUDA sources are C++17.)
struct RankSubsetCopy {
  size_t count = 0;
  const uint32_t* ids = nullptr;    // increasing
  const float* position = nullptr;  // xyz triples, m
  const float* velocity = nullptr;  // xyz triples, m/s
  const float* density = nullptr;   // kg/m^3
};

}  // namespace dysa
