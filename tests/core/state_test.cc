// Tests of StateHash and StateIsFinite (server/core/src/state.cc): the hash covers ids,
// positions and velocities in id order, so it does not depend on the storage order and changes
// with a single bit of any of them; the finiteness check catches a NaN or an Inf in any
// position or velocity component.
#include "dysa/core/state.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <limits>
#include <utility>

namespace dysa {
namespace {

// n particles with distinct positions and velocities, stored in id order.
State MakeState(size_t n) {
  State state;
  ParticleArrays& p = state.particles;
  p.Resize(n);
  for (size_t i = 0; i < n; ++i) {
    p.id[i] = uint32_t(i);
    p.position[i] = Vec3(0.1f * float(i), -0.25f * float(i), 1.0f + float(i));
    p.velocity[i] = Vec3(float(i), 0.5f, -0.125f * float(i));
  }
  return state;
}

// Swaps particles i and j in storage, every attribute with them.
void SwapSlots(ParticleArrays& p, size_t i, size_t j) {
  std::swap(p.id[i], p.id[j]);
  std::swap(p.position[i], p.position[j]);
  std::swap(p.velocity[i], p.velocity[j]);
  std::swap(p.pressure[i], p.pressure[j]);
  std::swap(p.density[i], p.density[j]);
}

Real FlipLowestBit(Real x) {
  uint32_t bits;
  std::memcpy(&bits, &x, sizeof bits);
  bits ^= 1u;
  std::memcpy(&x, &bits, sizeof bits);
  return x;
}

TEST(StateHashTest, DoesNotDependOnTheStorageOrder) {
  State a = MakeState(50);
  const uint64_t hash = StateHash(a);
  State b = a;
  // Reverse the storage, as the neighbour sort reorders it.
  for (size_t i = 0; i < 25; ++i) SwapSlots(b.particles, i, 49 - i);
  ASSERT_NE(b.particles.id[0], a.particles.id[0]);
  EXPECT_EQ(StateHash(b), hash);
}

TEST(StateHashTest, ChangesWithOneBitOfAPositionOrVelocity) {
  const State a = MakeState(20);
  const uint64_t hash = StateHash(a);
  for (int axis = 0; axis < 3; ++axis) {
    SCOPED_TRACE(axis);
    State moved = a;
    moved.particles.position[7][axis] = FlipLowestBit(moved.particles.position[7][axis]);
    EXPECT_NE(StateHash(moved), hash);
    State faster = a;
    faster.particles.velocity[13][axis] = FlipLowestBit(faster.particles.velocity[13][axis]);
    EXPECT_NE(StateHash(faster), hash);
  }
}

TEST(StateHashTest, IgnoresWhatIsNotPositionVelocityOrId) {
  // Density and pressure are recomputed each step; the hash leaves them out.
  State a = MakeState(10);
  const uint64_t hash = StateHash(a);
  a.particles.density[3] = 1000;
  a.particles.pressure[4] = 5;
  a.time = 1;
  a.step = 3;
  EXPECT_EQ(StateHash(a), hash);
  // Swapping two particles' positions (not their ids) is a different state.
  std::swap(a.particles.position[1], a.particles.position[2]);
  EXPECT_NE(StateHash(a), hash);
}

TEST(StateIsFiniteTest, TrueForAFiniteState) {
  EXPECT_TRUE(StateIsFinite(MakeState(100).particles));
  EXPECT_TRUE(StateIsFinite(MakeState(0).particles));
}

TEST(StateIsFiniteTest, CatchesNanOrInfInAnyPositionOrVelocityComponent) {
  const State a = MakeState(100);
  for (const Real bad :
       {std::numeric_limits<Real>::quiet_NaN(), std::numeric_limits<Real>::infinity(),
        -std::numeric_limits<Real>::infinity()}) {
    for (int axis = 0; axis < 3; ++axis) {
      SCOPED_TRACE(::testing::Message() << bad << " on axis " << axis);
      ParticleArrays position = a.particles;
      position.position[42][axis] = bad;
      EXPECT_FALSE(StateIsFinite(position));
      ParticleArrays velocity = a.particles;
      velocity.velocity[99][axis] = bad;
      EXPECT_FALSE(StateIsFinite(velocity));
    }
  }
  // Only positions and velocities count: a NaN density is not a diverged state.
  ParticleArrays density = a.particles;
  density.density[0] = std::numeric_limits<Real>::quiet_NaN();
  EXPECT_TRUE(StateIsFinite(density));
}

}  // namespace
}  // namespace dysa
