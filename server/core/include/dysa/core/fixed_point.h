// The fixed-point numbers of fixed_point_sum.h (which says why and bounds the sums): the scale,
// the clamp of a term, and the conversions. Apart from it so that CUDA code (C++17, without
// scene.h) rounds each term the same way (dfsph_pipeline.cu).
#pragma once

#include <cmath>
#include <cstdint>

namespace dysa {

inline constexpr int kFixedPointFractionBits = 32;
inline constexpr double kFixedPointScale = double(uint64_t{1} << kFixedPointFractionBits);
inline constexpr int kFixedPointMaxTermLog2 = 2;
inline constexpr double kFixedPointMaxTerm = double(1 << kFixedPointMaxTermLog2);

// The fixed-point integer of one term (a fraction), clamped and rounded to nearest (ties away
// from zero: std::llround does not depend on the floating-point rounding mode).
inline int64_t ToFixedPoint(double term) {
  if (std::isnan(term)) term = kFixedPointMaxTerm;
  if (term > kFixedPointMaxTerm) term = kFixedPointMaxTerm;
  if (term < -kFixedPointMaxTerm) term = -kFixedPointMaxTerm;
  return std::llround(term * kFixedPointScale);  // * 2^32: exact in double
}

// The fraction a fixed-point sum stands for (exact while |sum| < 2^53 2^-32, i.e. a sum below
// 2^21; beyond, rounded once, the same on every process).
inline double FromFixedPoint(int64_t sum) { return double(sum) / kFixedPointScale; }

}  // namespace dysa
