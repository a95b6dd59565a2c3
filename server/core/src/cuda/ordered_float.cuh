// Floats reduced exactly by integer atomics: a float's bits mapped to an unsigned integer of the
// same order (negative floats reversed below the positive ones; -0 just below +0), so that
// atomicMin / atomicMax over the mapped values give the float minimum and maximum in any order.
// Used by the device's position bounds (view_subset.cu, view_reads.cu).
#pragma once

#include <cstdint>
#include <cstring>

namespace dysa::cuda {

__host__ __device__ inline uint32_t Ordered(uint32_t bits) {
  return (bits & 0x80000000u) ? ~bits : (bits | 0x80000000u);
}

inline float FromOrdered(uint32_t u) {
  const uint32_t bits = (u & 0x80000000u) ? (u & 0x7fffffffu) : ~u;
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

inline constexpr uint32_t kOrderedPlusInf = 0xff800000u;   // Ordered(bits of +inf)
inline constexpr uint32_t kOrderedMinusInf = 0x007fffffu;  // Ordered(bits of -inf)

}  // namespace dysa::cuda
