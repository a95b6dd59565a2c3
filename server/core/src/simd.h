// Eight-lane float vectors (GCC/Clang vector extensions) for the neighbour loops.
//
// A neighbour loop accumulates into the 8 lanes independently, lane l taking candidates
// begin + l, begin + 8 + l, ... of a run, and adds the lanes up in a fixed order at the end. The
// arithmetic is therefore fixed by the source, not by the compiler: the same bits at -O0 and
// -O3, with SSE, AVX2 or AVX-512 (with -ffp-contract=off, which dysa_core sets), and for any
// thread count. Built for x86-64-v3 (AVX2) a vector is one register; on the baseline it is two.
#pragma once

#include <cstdint>
#include <cstring>

#include "dysa/core/types.h"

#if defined(__AVX__)
#include <immintrin.h>
#endif

namespace dysa::simd {

inline constexpr int kLanes = 8;
using RealV = Real __attribute__((vector_size(kLanes * sizeof(Real))));
using MaskV = int32_t __attribute__((vector_size(kLanes * sizeof(int32_t))));
static_assert(sizeof(Real) == sizeof(int32_t));

inline RealV Load(const Real* p) {
  RealV v;
  std::memcpy(&v, p, sizeof(v));
  return v;
}

inline RealV Broadcast(Real x) { return RealV{} + x; }

inline RealV Sqrt(RealV x) {
#if defined(__AVX__)
  return RealV(_mm256_sqrt_ps(__m256(x)));
#else
  for (int l = 0; l < kLanes; ++l) x[l] = __builtin_sqrtf(x[l]);
  return x;
#endif
}

// Lanes whose candidate index j + l lies before `end`.
inline MaskV InRun(uint32_t j, uint32_t end) {
  const MaskV lane = {0, 1, 2, 3, 4, 5, 6, 7};
  return (lane + int32_t(j)) < int32_t(end);
}

inline RealV Select(MaskV mask, RealV a, RealV b) { return mask ? a : b; }

inline Real Sum(RealV v) {
  Real s = 0;
  for (int l = 0; l < kLanes; ++l) s += v[l];
  return s;
}

inline bool Any(MaskV m) {
  int32_t any = 0;
  for (int l = 0; l < kLanes; ++l) any |= m[l];
  return any != 0;
}

}  // namespace dysa::simd
