// Simulation::ReadParticlesByIds and ReadPositionBounds on the CPU: the reads a view stream's
// frames make instead of a full read (docs/server.md, "View-dependent detail"), checked against
// a full read of the same state.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <vector>

#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "support/gpu_test.h"

namespace dysa {
namespace {

TEST(ViewReads, ReadParticlesByIdsWritesExactlyTheIdsEntriesWithTheFullReadsBits) {
  Simulation sim(testing::DamScene("wcsph"));
  for (int i = 0; i < 3; ++i) sim.StepFrame();
  const size_t n = sim.particle_count();
  std::vector<float> p(3 * n), v(3 * n), d(n);
  sim.ReadParticlesById({p, v, d});
  std::vector<uint32_t> ids;
  for (uint32_t k = 1; k < n; k += 5) ids.push_back(k);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<float> sp(3 * n, nan), sv(3 * n, nan), sd(n, nan);
  EXPECT_EQ(sim.ReadParticlesByIds(ids, {sp, sv, sd}), ids.size());
  for (uint32_t k = 0; k < n; ++k) {
    const bool asked = std::binary_search(ids.begin(), ids.end(), k);
    for (int a = 0; a < 3; ++a) {
      if (asked) {
        ASSERT_EQ(sp[3 * k + a], p[3 * k + a]) << k;
        ASSERT_EQ(sv[3 * k + a], v[3 * k + a]) << k;
      } else {
        ASSERT_TRUE(std::isnan(sp[3 * k + a]) && std::isnan(sv[3 * k + a])) << k << " written";
      }
    }
    if (asked) {
      ASSERT_EQ(sd[k], d[k]) << k;
    } else {
      ASSERT_TRUE(std::isnan(sd[k])) << k << " written";
    }
  }
  // Positions alone; nothing asked; errors.
  std::vector<float> only(3 * n, nan);
  sim.ReadParticlesByIds(ids, {only, {}, {}});
  EXPECT_EQ(only[3 * ids[3]], p[3 * ids[3]]);
  EXPECT_EQ(sim.ReadParticlesByIds({}, {only, {}, {}}), 0u);
  const std::vector<uint32_t> past = {uint32_t(n)};
  EXPECT_THROW(sim.ReadParticlesByIds(past, {only, {}, {}}), std::out_of_range);
  std::vector<float> short_array(3 * n - 1);
  EXPECT_THROW(sim.ReadParticlesByIds(ids, {short_array, {}, {}}), std::invalid_argument);
}

TEST(ViewReads, PositionBoundsAreEveryParticlesExtremes) {
  Simulation sim(testing::DamScene("dfsph"));
  for (int i = 0; i < 2; ++i) sim.StepFrame();
  const size_t n = sim.particle_count();
  std::vector<float> p(3 * n);
  sim.ReadParticlesById({p, {}, {}});
  const Simulation::PositionBounds b = sim.ReadPositionBounds();
  for (int a = 0; a < 3; ++a) {
    float lo = std::numeric_limits<float>::infinity(), hi = -lo;
    for (size_t i = 0; i < n; ++i) lo = std::min(lo, p[3 * i + a]), hi = std::max(hi, p[3 * i + a]);
    EXPECT_EQ(b.lo[a], lo) << a;
    EXPECT_EQ(b.hi[a], hi) << a;
    EXPECT_LT(b.lo[a], b.hi[a]);
  }
}

uint32_t Bits(float f) {
  uint32_t u;
  std::memcpy(&u, &f, sizeof u);
  return u;
}

// The bounds of a state written by hand (a checkpoint restored): a NaN skipped wherever it
// lies, an axis of NaNs alone +inf / -inf, and a zero extreme signed as the first zero in
// storage order (what a sequential scan keeps, and the GPU's reduction), whatever the threads.
TEST(ViewReads, PositionBoundsSkipNaNsAndSignAZeroAsTheFirstZeroInStorage) {
  Simulation sim(testing::DamScene("wcsph"));
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const Checkpoint start = sim.SaveCheckpoint();
  const size_t n = start.position.size();
  ASSERT_GT(n, 100u);
  for (const bool minus_first : {false, true}) {
    Checkpoint c = start;
    for (size_t i = 0; i < n; ++i) {
      c.position[i] = Vec3(0.5f + 1e-3f * float(i % 7), 0.0f, nan);  // y: every value a zero
    }
    const float first = minus_first ? -0.0f : 0.0f, later = minus_first ? 0.0f : -0.0f;
    c.position[0].x() = nan;
    c.position[n / 3].x() = first;  // x's smallest: a zero, of both signs
    c.position[n / 2].x() = later;
    c.position[n - 1].x() = later;
    c.position[n / 4].y() = first;  // y: the first zero decides both extremes
    for (size_t i = 0; i < n / 4; ++i) c.position[i].y() = nan;
    for (size_t i = n / 4 + 1; i < n; ++i) c.position[i].y() = later;
    sim.RestoreCheckpoint(c);
    const Simulation::PositionBounds b = sim.ReadPositionBounds();
    EXPECT_EQ(Bits(b.lo[0]), Bits(first)) << minus_first;
    EXPECT_EQ(b.hi[0], 0.5f + 1e-3f * 6.0f) << minus_first;
    EXPECT_EQ(Bits(b.lo[1]), Bits(first)) << minus_first;
    EXPECT_EQ(Bits(b.hi[1]), Bits(first)) << minus_first;
    EXPECT_EQ(b.lo[2], std::numeric_limits<float>::infinity());
    EXPECT_EQ(b.hi[2], -std::numeric_limits<float>::infinity());
  }
}

}  // namespace
}  // namespace dysa
