// Order-free sums of per-particle terms: each term is rounded to a 64-bit fixed-point integer
// on its own, and integers add exactly in any order. A sum split over threads or processes (each
// process sums its own particles, MPI_Allreduce adds the processes' integers) is then the same
// integer as the serial sum of one process, bit for bit, whatever the split and the order. A
// floating-point sum is not: (a + b) + c != a + (b + c), so a decision taken on it (dfsph's
// stopping test) could differ between one process and N.
//
// The scale. A term is a dimensionless fraction (dfsph: a density error over rho0), kept to
// kFixedPointFractionBits = 32 bits below the point: a resolution of 2^-32 = 2.3e-10, 430 times
// finer than the smallest tolerance a scene may set (1e-7, params.cc), and finer than a float
// density near rho0 holds (2^-24 of it). Rounding to nearest moves a mean by at most 2^-33.
//
// The overflow bound. A term is clamped to [-kFixedPointMaxTerm, kFixedPointMaxTerm] = [-4, 4]
// (a particle compressed to 5 rho0 has collapsed: the stopping test is far from passing, and the
// grid's crowding alarm and dfsph's speed limit report it), so a term is at most 2^34 in magnitude,
// and a scene has at most kMaxParticles = 5e8 < 2^29 particles (scene.h): |sum| <= 5e8 * 2^34
// = 8.6e18 < 2^63 - 1 = 9.2e18 (static_assert below). A NaN term (a diverged particle) counts as
// +kFixedPointMaxTerm: the largest error, never a converged one.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "dysa/core/fixed_point.h"
#include "dysa/core/scene.h"

namespace dysa {

static_assert(kMaxParticles < (uint64_t{1} << 29), "the overflow bound assumes n < 2^29");
static_assert(kMaxParticles * (uint64_t{1} << (kFixedPointFractionBits + kFixedPointMaxTermLog2)) <
                  uint64_t(std::numeric_limits<int64_t>::max()),
              "kMaxParticles terms of the largest magnitude must not overflow an int64_t");

// sum_i ToFixedPoint(double(values[i]) * factor) over i in [0, n) where skip is null or
// skip[i] == 0. Each term is the product of a float converted exactly to double and the same
// double factor on every process, so its rounding does not depend on who sums it.
template <class Value>
int64_t FixedPointSum(const Value* values, size_t n, double factor, const uint8_t* skip) {
  int64_t sum = 0;
  // Integers: the threads' partial sums add to the same total in any order.
#pragma omp parallel for schedule(static) reduction(+ : sum)
  for (size_t i = 0; i < n; ++i) {
    if (skip && skip[i]) continue;
    sum += ToFixedPoint(double(values[i]) * factor);
  }
  return sum;
}

}  // namespace dysa
