// Tests of the order-free fixed-point sum (server/core/include/dysa/core/fixed_point_sum.h), which
// dfsph's stopping tests use so that one process and N give the same iteration counts: any order
// and any split of the terms give the same integer; a float sum of the same terms does not; terms
// are clamped, NaN counts as the largest; the documented overflow bound holds.
#include "dysa/core/fixed_point_sum.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "dysa/core/types.h"
#include "support/with_threads.h"

namespace dysa {
namespace {

// Errors as dfsph's solves see them: kg/m^3 over rho0 = 1000, from 0 to 5% of rho0 and a few
// large ones, spread over nine decades so that a float sum rounds differently in each order.
std::vector<Real> Errors(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> decade(-7, 2);
  std::vector<Real> errors(n);
  for (Real& e : errors) e = Real(std::pow(10.0, decade(rng)));
  return errors;
}

TEST(FixedPointSumTest, AnyOrderGivesTheSameBits) {
  std::vector<Real> errors = Errors(100'000, 1);
  const double factor = 1e-3;  // 1 / rho0
  const int64_t reference = FixedPointSum(errors.data(), errors.size(), factor, nullptr);
  EXPECT_GT(reference, 0);
  std::mt19937 rng(2);
  // A float sum of the same terms in another order gives other bits (the reason for the
  // fixed point): seen at least once over the shuffles.
  bool float_sums_differ = false;
  double serial = 0;
  for (Real e : errors) serial += double(e) * factor;
  for (int shuffle = 0; shuffle < 5; ++shuffle) {
    std::shuffle(errors.begin(), errors.end(), rng);
    EXPECT_EQ(FixedPointSum(errors.data(), errors.size(), factor, nullptr), reference);
    // As a float, so that the order's rounding shows at this size.
    float forward = 0, backward = 0;
    for (Real e : errors) forward += Real(double(e) * factor);
    std::reverse(errors.begin(), errors.end());
    for (Real e : errors) backward += Real(double(e) * factor);
    float_sums_differ = float_sums_differ || forward != backward;
  }
  EXPECT_TRUE(float_sums_differ);
  // The fixed-point mean is the exact mean within half a unit of 2^-32 per term.
  EXPECT_NEAR(FromFixedPoint(reference), serial, 1e-8 * serial + errors.size() * 0x1p-33);
}

TEST(FixedPointSumTest, AnySplitOverProcessesAndThreadsGivesTheSameBits) {
  const std::vector<Real> errors = Errors(30'011, 3);
  const double factor = 0.002 / 1000;  // dt / rho0, the divergence solve's
  const int64_t whole = FixedPointSum(errors.data(), errors.size(), factor, nullptr);
  // Split into 2 to 7 "processes" at arbitrary cuts, each summing its part; the parts' integer
  // sum (what MPI_Allreduce adds) is the whole.
  std::mt19937 rng(4);
  for (int parts = 2; parts <= 7; ++parts) {
    std::vector<size_t> cuts = {0, errors.size()};
    for (int k = 1; k < parts; ++k) cuts.push_back(rng() % errors.size());
    std::sort(cuts.begin(), cuts.end());
    int64_t total = 0;
    for (size_t k = 0; k + 1 < cuts.size(); ++k) {
      total += FixedPointSum(errors.data() + cuts[k], cuts[k + 1] - cuts[k], factor, nullptr);
    }
    EXPECT_EQ(total, whole) << parts << " parts";
  }
  // Ghost flags: a process skips the particles another owns; owned and ghost halves add up.
  std::vector<uint8_t> odd(errors.size()), even(errors.size());
  for (size_t i = 0; i < errors.size(); ++i) (i % 2 ? even : odd)[i] = 1;
  EXPECT_EQ(FixedPointSum(errors.data(), errors.size(), factor, odd.data()) +
                FixedPointSum(errors.data(), errors.size(), factor, even.data()),
            whole);
  // Threads: the OpenMP reduction over integers.
  for (int threads : {1, 2, 3, 8}) {
    const int64_t sum = dysa::testing::WithThreads(
        threads, [&] { return FixedPointSum(errors.data(), errors.size(), factor, nullptr); });
    EXPECT_EQ(sum, whole) << threads << " threads";
  }
}

TEST(FixedPointSumTest, RoundsEachTermToTwoToTheMinus32) {
  EXPECT_EQ(ToFixedPoint(0), 0);
  EXPECT_EQ(ToFixedPoint(1), int64_t{1} << 32);
  EXPECT_EQ(ToFixedPoint(-0.5), -(int64_t{1} << 31));
  EXPECT_EQ(ToFixedPoint(0x1p-32), 1);
  EXPECT_EQ(ToFixedPoint(0x1p-33), 1);  // a tie rounds away from zero
  EXPECT_EQ(ToFixedPoint(0x1p-34), 0);  // below half a unit
  EXPECT_EQ(FromFixedPoint(ToFixedPoint(0.125)), 0.125);
}

TEST(FixedPointSumTest, ClampsTermsAndCountsNanAsTheLargest) {
  const int64_t max = int64_t(kFixedPointMaxTerm * kFixedPointScale);
  EXPECT_EQ(max, int64_t{1} << 34);
  EXPECT_EQ(ToFixedPoint(kFixedPointMaxTerm), max);
  EXPECT_EQ(ToFixedPoint(1e30), max);
  EXPECT_EQ(ToFixedPoint(std::numeric_limits<double>::infinity()), max);
  EXPECT_EQ(ToFixedPoint(-1e30), -max);
  EXPECT_EQ(ToFixedPoint(std::numeric_limits<double>::quiet_NaN()), max);
}

TEST(FixedPointSumTest, TheOverflowBoundHolds) {
  // kMaxParticles terms of the largest magnitude, added as the sum adds them, stay within an
  // int64_t: |term| <= INT64_MAX / kMaxParticles (rounded down), so n |term| <= INT64_MAX.
  const int64_t per_term = std::numeric_limits<int64_t>::max() / int64_t(kMaxParticles);
  EXPECT_LE(ToFixedPoint(kFixedPointMaxTerm), per_term);
  EXPECT_LE(-ToFixedPoint(-kFixedPointMaxTerm), per_term);
  // The margin is what the header says, not an accident of the clamp: a clamp at twice the
  // largest term would overflow.
  EXPECT_GT(2 * ToFixedPoint(kFixedPointMaxTerm), per_term);
}

}  // namespace
}  // namespace dysa
