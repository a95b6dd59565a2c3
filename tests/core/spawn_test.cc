// Tests of SpawnParticles and SpawnParticleRadius (server/core/src/spawn.cc): how many particles
// each block spawns and where (edge to edge for a count, cell centres for a spacing, the
// physical solvers' particle_spacing), the jitter's bounds and its determinism by seed, ids that
// are a permutation of 0 .. n-1, the blocks' initial velocities, and no fluid inside obstacles.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <set>
#include <tuple>
#include <vector>

#include "dysa/core/params.h"
#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"

namespace dysa {
namespace {

ParticleArrays Spawn(const Scene& scene) {
  ParticleArrays particles;
  SpawnParticles(scene, scene.params, particles);
  return particles;
}

// The sorted distinct values of coordinate `axis` over all particles.
std::vector<double> Coordinates(const ParticleArrays& p, int axis) {
  std::set<double> values;
  for (const Vec3& x : p.position) values.insert(double(x[axis]));
  return {values.begin(), values.end()};
}

TEST(SpawnTest, CountsArePerAxisCountsOrParticleQuantityCubedSummedOverBlocks) {
  Scene scene = ParseScene(R"({"fluid_blocks": [
      {"center": [-2, 0, 0], "size": 1, "particles_per_axis": [3, 4, 5]},
      {"center": [2, 0, 0], "size": 1}]})");
  SetParam(scene.params, "particle_quantity", 6);
  EXPECT_EQ(Spawn(scene).size(), 3u * 4 * 5 + 6 * 6 * 6);
  // No block, no particle.
  scene.fluid_blocks.clear();
  EXPECT_EQ(Spawn(scene).size(), 0u);
}

TEST(SpawnTest, ACountSpansTheBlockEdgeToEdgeAtEvenSpacing) {
  const Scene scene = ParseScene(R"({"fluid_blocks": [
      {"center": [0.5, -1, 2], "size": [1, 2, 3], "particles_per_axis": [5, 3, 4],
       "jitter": 0}]})");
  const ParticleArrays p = Spawn(scene);
  ASSERT_EQ(p.size(), 60u);
  const Vec3d center(0.5, -1, 2), size(1, 2, 3);
  const Eigen::Vector3i n(5, 3, 4);
  for (int a = 0; a < 3; ++a) {
    SCOPED_TRACE(a);
    const std::vector<double> c = Coordinates(p, a);
    ASSERT_EQ(c.size(), size_t(n[a]));
    EXPECT_NEAR(c.front(), center[a] - size[a] / 2, 1e-6);
    EXPECT_NEAR(c.back(), center[a] + size[a] / 2, 1e-6);
    for (size_t k = 1; k < c.size(); ++k) {
      EXPECT_NEAR(c[k] - c[k - 1], size[a] / (n[a] - 1), 1e-6);
    }
  }
}

TEST(SpawnTest, ASpacingFillsTheBlockWithCellCentres) {
  // 1.0 / 0.25 = 4 cells per axis; the points sit half a spacing inside each face.
  const Scene scene = ParseScene(R"({"fluid_blocks": [
      {"center": [0, 0, 0], "size": [1, 0.5, 1], "spacing": 0.25, "jitter": 0}]})");
  const ParticleArrays p = Spawn(scene);
  ASSERT_EQ(p.size(), 4u * 2 * 4);
  EXPECT_EQ(Coordinates(p, 0), (std::vector<double>{-0.375, -0.125, 0.125, 0.375}));
  EXPECT_EQ(Coordinates(p, 1), (std::vector<double>{-0.125, 0.125}));
}

TEST(SpawnTest, PhysicalSolversFillAtParticleSpacingWithoutJitterByDefault) {
  Scene scene = ParseScene(R"({"solver": "wcsph",
      "fluid_blocks": [{"center": [0, 0, 0], "size": [0.4, 0.2, 0.2]}]})");
  SetParam(scene.params, "particle_spacing", 0.05);
  ASSERT_GT(scene.params.spawn_jitter, 0);  // the seed's default, ignored here
  const ParticleArrays p = Spawn(scene);
  ASSERT_EQ(p.size(), 8u * 4 * 4);
  const std::vector<double> x = Coordinates(p, 0);
  ASSERT_EQ(x.size(), 8u);  // exactly on the lattice: no jitter
  for (size_t k = 1; k < x.size(); ++k) EXPECT_NEAR(x[k] - x[k - 1], 0.05, 1e-6);
  EXPECT_NEAR(x.front(), -0.175, 1e-6);
}

TEST(SpawnTest, JitterMovesEachParticleAtMostItsRadiusFromItsLatticePoint) {
  Scene scene = ParseScene(R"({"fluid_blocks": [
      {"size": 2, "particles_per_axis": 7, "jitter": 0.05, "seed": 7}]})");
  const ParticleArrays jittered = Spawn(scene);
  scene.fluid_blocks[0].jitter = 0;
  const ParticleArrays lattice = Spawn(scene);
  ASSERT_EQ(jittered.size(), lattice.size());
  double largest = 0;
  size_t moved = 0;
  for (size_t i = 0; i < jittered.size(); ++i) {
    ASSERT_EQ(jittered.id[i], lattice.id[i]);
    const double offset = (jittered.position[i] - lattice.position[i]).cast<double>().norm();
    EXPECT_LE(offset, 0.05 + 1e-6) << "particle " << i;
    largest = std::max(largest, offset);
    moved += offset > 0 ? 1 : 0;
  }
  EXPECT_EQ(moved, jittered.size());
  // Uniform in the ball: among 343 offsets the largest comes close to the radius.
  EXPECT_GT(largest, 0.04);
}

TEST(SpawnTest, JitterIsDeterministicBySeed) {
  Scene scene = ParseScene(R"({"fluid_blocks": [
      {"size": 1, "particles_per_axis": 5, "jitter": 0.02, "seed": 5}]})");
  const ParticleArrays a = Spawn(scene);
  const ParticleArrays b = Spawn(scene);
  EXPECT_EQ(a.position, b.position);
  scene.fluid_blocks[0].seed = 6;
  const ParticleArrays c = Spawn(scene);
  ASSERT_EQ(c.size(), a.size());
  size_t differ = 0;
  for (size_t i = 0; i < a.size(); ++i) differ += a.position[i] != c.position[i] ? 1 : 0;
  EXPECT_EQ(differ, a.size());
}

TEST(SpawnTest, IdsAreAPermutationAcrossBlocks) {
  const Scene scene = ParseScene(R"({"fluid_blocks": [
      {"center": [-2, 0, 0], "size": 1, "particles_per_axis": 4},
      {"center": [2, 0, 0], "size": 1, "particles_per_axis": [2, 3, 5]}]})");
  const ParticleArrays p = Spawn(scene);
  ASSERT_EQ(p.size(), 64u + 30u);
  std::vector<uint32_t> ids = p.id;
  std::sort(ids.begin(), ids.end());
  for (size_t i = 0; i < ids.size(); ++i) ASSERT_EQ(ids[i], i);
}

TEST(SpawnTest, EachBlockStartsWithItsVelocityAndNothingElseIsSet) {
  const Scene scene = ParseScene(R"({"fluid_blocks": [
      {"center": [-2, 0, 0], "size": 1, "particles_per_axis": 3, "velocity": [1, -2, 0.5]},
      {"center": [2, 0, 0], "size": 1, "particles_per_axis": 2}]})");
  const ParticleArrays p = Spawn(scene);
  ASSERT_EQ(p.size(), 27u + 8u);
  for (size_t i = 0; i < p.size(); ++i) {
    SCOPED_TRACE(i);
    Vec3 expected = Vec3::Zero();
    if (p.position[i].x() < 0) expected = Vec3(1.0f, -2.0f, 0.5f);
    EXPECT_EQ(p.velocity[i], expected);
    EXPECT_EQ(p.density[i], 0);
    EXPECT_EQ(p.pressure[i], 0);
  }
}

TEST(SpawnTest, NoParticleStartsInsideAnObstacle) {
  const Scene scene = ParseScene(R"({
    "domain": {"min": [-2, -2, -2], "max": [2, 2, 2]},
    "fluid_blocks": [{"size": [2, 2, 2], "particles_per_axis": 11, "jitter": 0}],
    "obstacles": [{"type": "sphere", "center": [0, 0, 0], "radius": 0.5},
                  {"type": "box", "center": [0.8, 0.8, 0.8], "size": [0.5, 0.5, 0.5]}]
  })");
  Simulation sim(scene);
  const ParticleArrays& p = sim.state().particles;
  // 11^3 lattice points 0.2 m apart: the 81 within 0.5 m of the centre and the 3^3 with every
  // coordinate in {0.6, 0.8, 1.0}, inside the box, are left out.
  EXPECT_EQ(p.size(), 1331u - 81u - 27u);
  std::vector<uint32_t> ids(p.id.begin(), p.id.end());
  std::sort(ids.begin(), ids.end());
  for (size_t i = 0; i < ids.size(); ++i) ASSERT_EQ(ids[i], i);  // still 0 .. n-1
  for (size_t i = 0; i < p.size(); ++i) {
    EXPECT_GE(p.position[i].cast<double>().norm(), 0.5);
    EXPECT_FALSE((p.position[i].array() > 0.55f).all());
  }
}

TEST(SpawnParticleRadiusTest, TakesTheSmallestSpacingOverBlocksAndAxes) {
  Scene scene = ParseScene(R"({"fluid_blocks": [
      {"size": [1, 2, 3], "particles_per_axis": [11, 11, 1]},
      {"size": [1, 1, 1], "spacing": 0.25}]})");
  EXPECT_DOUBLE_EQ(SpawnParticleRadius(scene, scene.params), 0.5 * 0.1);  // 1 m / 10
  scene.fluid_blocks[1].spacing = 0.05;
  EXPECT_DOUBLE_EQ(SpawnParticleRadius(scene, scene.params), 0.5 * 0.05);
  // One particle per block: no spacing; half the smoothing radius.
  scene = ParseScene(R"({"fluid_blocks": [{"particles_per_axis": 1}]})");
  EXPECT_DOUBLE_EQ(SpawnParticleRadius(scene, scene.params), 0.5 * scene.params.smoothing_radius);
}

// The radius is half the distance between neighbouring spawned particles (no jitter): the
// rule above and the spawner's lattice agree.
TEST(SpawnParticleRadiusTest, IsHalfTheClosestDistanceOfTheSpawnedParticles) {
  for (const char* json :
       {R"({"fluid_blocks": [{"size": [1, 2, 3], "particles_per_axis": [5, 7, 4],
                                                 "jitter": 0}]})",
        R"({"fluid_blocks": [{"size": [1, 1, 1], "spacing": 0.2, "jitter": 0}]})"}) {
    const Scene scene = ParseScene(json);
    ParticleArrays particles;
    SpawnParticles(scene, scene.params, particles);
    double closest = std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < particles.size(); ++i) {
      for (size_t j = i + 1; j < particles.size(); ++j) {
        closest = std::min(closest, double((particles.position[i] - particles.position[j]).norm()));
      }
    }
    EXPECT_NEAR(SpawnParticleRadius(scene, scene.params), 0.5 * closest, 1e-6) << json;
  }
}

}  // namespace
}  // namespace dysa
