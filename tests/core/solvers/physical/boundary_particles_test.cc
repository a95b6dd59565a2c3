// Tests of server/core/src/solvers/physical/boundary_particles.{h,cc}: samples lie behind the
// surfaces, a flat wall's particles weigh like the fluid they replace, and a fluid lattice at rest
// has the rest density everywhere, walls, edges and corners included.
#include "solvers/physical/boundary_particles.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "solvers/physical/physical_passes.h"
#include "solvers/wcsph/becker_teschner_solver.h"

namespace dysa {
namespace {

const Aabb kDomain{Vec3d(0, 0, 0), Vec3d(0.4, 0.2, 0.1)};
constexpr double kD = 0.02;

TEST(SampleDomainWallsTest, TwoLayersOutsideTheDomainOnEverySide) {
  std::vector<Vec3> points, fluid_side;
  SampleDomainWalls(kDomain, {}, kD, 2, points, &fluid_side);
  // The lattice of the grown box (24 x 14 x 9) less the domain's (20 x 10 x 5).
  EXPECT_EQ(points.size(), 24u * 14 * 9 - 20 * 10 * 5);
  for (const Vec3& p : points) {
    const Vec3d x = p.cast<double>();
    EXPECT_FALSE(kDomain.Contains(x));
    EXPECT_TRUE((Aabb{kDomain.min - Vec3d::Constant(2 * kD), kDomain.max + Vec3d::Constant(2 * kD)})
                    .Contains(x));
  }
  for (const Vec3& p : fluid_side) EXPECT_TRUE(kDomain.Contains(p.cast<double>()));
}

TEST(SampleDomainWallsTest, NoWallsAcrossAPeriodicAxis) {
  std::vector<Vec3> points, fluid_side;
  SampleDomainWalls(kDomain, {true, false, true}, kD, 2, points, &fluid_side);
  // Only the floor and the ceiling: the x-z lattice (20 x 5) two layers deep on each.
  EXPECT_EQ(points.size(), 20u * 5 * 2 * 2);
  for (const Vec3& p : points) {
    const Vec3d x = p.cast<double>();
    EXPECT_TRUE(x.y() < kDomain.min.y() || x.y() > kDomain.max.y());
    EXPECT_TRUE(x.x() > kDomain.min.x() && x.x() < kDomain.max.x());
    EXPECT_TRUE(x.z() > kDomain.min.z() && x.z() < kDomain.max.z());
  }
  // The fluid side: the two layers next to the floor and the ceiling.
  EXPECT_EQ(fluid_side.size(), 20u * 5 * 2 * 2);
}

TEST(SampleObstaclesTest, SpheresAndBoxesAreSampledInside) {
  std::vector<Vec3> points, fluid_side;
  const SphereObstacle sphere{Vec3d(0.1, 0.1, 0.05), 0.05, {}};
  SampleSphere(sphere, kD, 2, points, &fluid_side);
  ASSERT_FALSE(points.empty());
  for (const Vec3& p : points) {
    const double r = (p.cast<double>() - sphere.center).norm();
    EXPECT_LT(r, sphere.radius);
    EXPECT_GT(r, sphere.radius - 2 * kD);
  }
  for (const Vec3& p : fluid_side) EXPECT_GT((p.cast<double>() - sphere.center).norm(), 0.05);
  // About 4 pi r^2 / d^2 points on the outer shell (r = R - d/2).
  const double shell = 4 * M_PI * 0.04 * 0.04 / (kD * kD);
  EXPECT_NEAR(double(points.size()), shell + 4 * M_PI * 0.02 * 0.02 / (kD * kD), 2);

  points.clear();
  const Aabb box{Vec3d(0.2, 0, 0), Vec3d(0.3, 0.12, 0.1)};
  SampleBox(box, kD, 2, points);
  EXPECT_EQ(points.size(), 5u * 6 * 5 - 1 * 2 * 1);  // all but the core deeper than 2 d
  for (const Vec3& p : points) EXPECT_TRUE(box.Contains(p.cast<double>()));
}

Scene FilledDomain() {
  Scene scene = ParseScene(R"({
    "domain": {"min": [0, 0, 0], "max": [0.4, 0.2, 0.1]},
    "fluid_blocks": [{"center": [0.2, 0.1, 0.05], "size": [0.4, 0.2, 0.1]}],
    "solver": "wcsph",
    "params": {"particle_spacing": 0.02, "gravity": 0}
  })");
  return scene;
}

TEST(BoundaryParticlesTest, FlatWallsWeighLikeTheFluidTheyReplace) {
  const Simulation sim(FilledDomain());
  const BoundaryParticles boundary(sim.model(), kD, 2 * kD);
  ASSERT_GT(boundary.size(), 0u);
  // Every wall of a box is a lattice plane, so the volume of every particle of the layer next
  // to the fluid (faces, edges, corners) is d^3. (The outer layer lacks neighbours beyond it
  // and weighs more, but it is 2 d from any fluid particle, where the kernel is 0.)
  const NeighborGrid& grid = boundary.grid();
  int inner = 0;
  for (size_t b = 0; b < boundary.size(); ++b) {
    const Vec3d x(grid.xs()[b], grid.ys()[b], grid.zs()[b]);
    const Vec3d outside = (kDomain.min - x).cwiseMax(x - kDomain.max).cwiseMax(0.0);
    if (outside.maxCoeff() > kD) continue;
    ++inner;
    EXPECT_NEAR(boundary.volume()[b], kD * kD * kD, 1e-3 * kD * kD * kD);
  }
  EXPECT_EQ(inner, 22 * 12 * 7 - 20 * 10 * 5);
}

TEST(BoundaryParticlesTest, AFluidLatticeAtRestHasTheRestDensityAtEveryWall) {
  Simulation sim(FilledDomain());
  wcsph::BeckerTeschnerData data;  // the boundary at the scene's spacing kD, support 2 kD
  data.SampleBoundary(sim.model());
  State state = sim.state();
  physical::SortIntoGrid(sim.model(), state);
  wcsph::ComputePressure(sim.model(), data, state);
  const auto& density = state.particles.density;
  ASSERT_EQ(density.size(), 20u * 10 * 5);
  const auto [lo, hi] = std::minmax_element(density.begin(), density.end());
  EXPECT_NEAR(*lo, 1000, 0.1);
  EXPECT_NEAR(*hi, 1000, 0.1);
  // At rest nothing is compressed (to 1e-4), so no pressure pushes the lattice apart.
  for (Real p : state.particles.pressure) EXPECT_LT(p, 1e-4 * 1000 * 50 * 50);
}

// A larger support reaches deeper behind the walls: as many layers as it spans, and the lattice
// at rest still has the rest density at every wall with Wendland C2 at h = 1.732 d.
TEST(BoundaryParticlesTest, ALargerSupportGetsTheLayersItReaches) {
  EXPECT_EQ(BoundaryParticles::LayersFor(2 * kD, kD), 2);
  EXPECT_EQ(BoundaryParticles::LayersFor(2 * 1.3 * kD, kD), 3);
  EXPECT_EQ(BoundaryParticles::LayersFor(2 * 1.732 * kD, kD), 4);
  EXPECT_EQ(BoundaryParticles::LayersFor(kD, kD), 2);  // never fewer than two
  Scene scene = FilledDomain();
  SetParam(scene.params, "kernel", 1);
  SetParam(scene.params, "smoothing_length_ratio", 1.732);
  Simulation sim(scene);
  wcsph::BeckerTeschnerData data;
  data.SampleBoundary(sim.model());
  EXPECT_EQ(data.boundary->size(), 28u * 18 * 13 - 20 * 10 * 5);
  State state = sim.state();
  physical::SortIntoGrid(sim.model(), state);
  wcsph::ComputePressure(sim.model(), data, state);
  const auto& density = state.particles.density;
  const auto [lo, hi] = std::minmax_element(density.begin(), density.end());
  EXPECT_NEAR(*lo, 1000, 0.1);
  EXPECT_NEAR(*hi, 1000, 0.1);
}

// Periodic in x and z, walls in y: the lattice filling the domain continues across the seams,
// so at rest every particle has the rest density, at the seams as in the middle and at the
// walls, and the walls are sampled only where they are.
TEST(BoundaryParticlesTest, APeriodicDomainFilledAtRestHasTheRestDensityEverywhere) {
  // 6 layers in z: a period needs at least 3 kernel supports (2 d each).
  Scene scene = ParseScene(R"({
    "domain": {"min": [0, 0, 0], "max": [0.4, 0.2, 0.12], "periodic": [true, false, true]},
    "fluid_blocks": [{"center": [0.2, 0.1, 0.06], "size": [0.4, 0.2, 0.12]}],
    "solver": "wcsph",
    "params": {"particle_spacing": 0.02, "gravity": 0}
  })");
  Simulation sim(scene);
  const BoundaryParticles boundary(sim.model(), kD, 2 * kD);
  EXPECT_EQ(boundary.size(), 20u * 6 * 2 * 2);
  wcsph::BeckerTeschnerData data;
  data.SampleBoundary(sim.model());
  State state = sim.state();
  physical::SortIntoGrid(sim.model(), state);
  wcsph::ComputePressure(sim.model(), data, state);
  const auto& density = state.particles.density;
  ASSERT_EQ(density.size(), 20u * 10 * 6);
  const auto [lo, hi] = std::minmax_element(density.begin(), density.end());
  EXPECT_NEAR(*lo, 1000, 0.1);
  EXPECT_NEAR(*hi, 1000, 0.1);
}

}  // namespace
}  // namespace dysa
