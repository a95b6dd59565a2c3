// Tests of particle shifting (server/core/src/solvers/physical/particle_shifting.cc): nothing
// moves on a uniform lattice, at a wall or on the free surface; a displaced particle is sent back
// towards its site, in proportion to its speed; the pass sits before the integration only where
// it is on; and in a dam break it keeps the particles from clumping.
#include "solvers/physical/particle_shifting.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "solvers/physical/physical_passes.h"

namespace dysa {
namespace {

using physical::PhysicalData;

// Water at rest, 8 x 8 x 8 particles of 0.02 m in a closed box just large enough (its walls'
// boundary particles in reach of the outer layers), and its top 0.1 m of air.
Scene TankScene(double shifting) {
  Scene scene = ParseScene(R"({
    "domain": {"min": [0, 0, 0], "max": [0.16, 0.26, 0.16]},
    "fluid_blocks": [{"center": [0.08, 0.08, 0.08], "size": [0.16, 0.16, 0.16]}],
    "solver": "wcsph",
    "params": {"particle_spacing": 0.02, "speed_of_sound": 20, "kinematic_viscosity": 0}
  })");
  SetParam(scene.params, "particle_shifting", shifting);
  return scene;
}

// The shift of every particle of `sim`'s lattice (by id) moving at `velocity`, with particle
// `moved` (an id) displaced by `offset`.
std::vector<Vec3> Shifts(const Simulation& sim, const Vec3& velocity, uint32_t moved = 0,
                         const Vec3& offset = Vec3::Zero()) {
  State state = sim.state();
  ParticleArrays& p = state.particles;
  for (size_t i = 0; i < p.size(); ++i) {
    p.velocity[i] = velocity;
    p.density[i] = Real(sim.params().rest_density);
    if (p.id[i] == moved) p.position[i] += offset;
  }
  PhysicalData data;
  data.SampleBoundary(sim.model());
  physical::SortIntoGrid(sim.model(), state);
  physical::ComputeParticleShifting(sim.model(), data, state);
  std::vector<Vec3> by_id(p.size());
  for (size_t i = 0; i < p.size(); ++i) by_id.at(p.id[i]) = data.shift[i];
  return by_id;
}

// The id of the particle nearest `x`.
uint32_t NearestId(const Simulation& sim, const Vec3& x) {
  const ParticleArrays& p = sim.state().particles;
  size_t best = 0;
  for (size_t i = 1; i < p.size(); ++i) {
    if ((p.position[i] - x).norm() < (p.position[best] - x).norm()) best = i;
  }
  return p.id[best];
}

TEST(ParticleShiftingTest, LeavesAUniformLatticeWallsAndTheSurfaceAlone) {
  const Simulation sim(TankScene(2));
  const std::vector<Vec3> shifts = Shifts(sim, Vec3(1, 0, 0));
  const ParticleArrays& p = sim.state().particles;
  double largest = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    const Vec3 shift = shifts[p.id[i]];
    if (p.position[i].y() > 0.15) {
      EXPECT_EQ(shift, Vec3::Zero()) << "a surface particle at " << p.position[i].transpose();
    }
    largest = std::max(largest, double(shift.norm()));
  }
  // A h |v| grad C: grad C of a full lattice, walls included, is 0 up to the rounding and the
  // wall lattice's truncation (measured 3.6e-5 m/s, in a corner); a particle displaced by d / 5
  // gets 0.35 m/s (below).
  EXPECT_LT(largest, 1e-3);
}

TEST(ParticleShiftingTest, SendsADisplacedParticleBackInProportionToItsSpeed) {
  const Simulation sim(TankScene(2));
  const uint32_t id = NearestId(sim, Vec3(0.07, 0.07, 0.07));
  const Vec3 offset(0.004, 0.002, 0);  // d / 5 along x, d / 10 along y
  const std::vector<Vec3> slow = Shifts(sim, Vec3(0.5, 0, 0), id, offset);
  const std::vector<Vec3> fast = Shifts(sim, Vec3(0, -1, 0), id, offset);
  // Back towards its site: against the displacement, mostly along it.
  EXPECT_LT(fast[id].dot(offset), -0.9 * fast[id].norm() * offset.norm());
  EXPECT_GT(fast[id].norm(), 0.2);  // measured 0.355 m/s at 1 m/s
  // |v| scales the shift, its direction does not matter.
  EXPECT_NEAR(fast[id].norm(), 2 * slow[id].norm(), 1e-6);
  // At rest nothing shifts.
  for (const Vec3& shift : Shifts(sim, Vec3::Zero(), id, offset)) EXPECT_EQ(shift, Vec3::Zero());
}

TEST(ParticleShiftingTest, RunsBeforeTheIntegrationOnlyWhereItIsOn) {
  const std::vector<std::string> off = Simulation(TankScene(0)).PassNames();
  EXPECT_EQ(std::count(off.begin(), off.end(), "shifting"), 0);
  const std::vector<std::string> on = Simulation(TankScene(2)).PassNames();
  ASSERT_GE(on.size(), 2u);
  EXPECT_EQ(on[on.size() - 2], "shifting");
  EXPECT_EQ(on.back(), "integrate");
  Scene corrector = TankScene(2);
  SetParam(corrector.params, "time_integration", 1);
  const std::vector<std::string> names = Simulation(corrector).PassNames();
  EXPECT_EQ(names[names.size() - 2], "shifting");
  EXPECT_EQ(names.back(), "correct");
}

// A 600-particle dam breaking in a 0.6 x 0.4 m tank, `shifting` the particle shifting's A.
Scene DamScene(double shifting) {
  Scene scene = ParseScene(R"({
    "domain": {"min": [0, 0, 0], "max": [0.6, 0.4, 0.08]},
    "fluid_blocks": [{"center": [0.1, 0.15, 0.04], "size": [0.2, 0.3, 0.08]}],
    "solver": "wcsph",
    "params": {"gravity": -9.81, "particle_spacing": 0.02, "speed_of_sound": 25,
               "kinematic_viscosity": 1e-5}
  })");
  SetParam(scene.params, "particle_shifting", shifting);
  return scene;
}

// The fraction of particles whose nearest neighbour is closer than 0.6 d, over snapshots every
// 0.1 s up to `seconds`: the clumps that shifting is there to spread.
double ClumpedFraction(const Scene& scene, double seconds) {
  Simulation sim(scene);
  const double d = sim.params().particle_spacing;
  size_t clumped = 0, samples = 0;
  for (int k = 1; k * 0.1 <= seconds + 1e-9; ++k) {
    while (sim.time() < k * 0.1) sim.Step(k * 0.1);
    EXPECT_TRUE(sim.alarm().empty()) << sim.alarm();
    const std::vector<Vec3>& x = sim.state().particles.position;
    for (size_t i = 0; i < x.size(); ++i) {
      double nearest = 1;
      for (size_t j = 0; j < x.size(); ++j) {
        if (j != i) nearest = std::min(nearest, double((x[i] - x[j]).norm()));
      }
      clumped += nearest < 0.6 * d;
      ++samples;
    }
  }
  return double(clumped) / double(samples);
}

// Over the collapse and the run-up (0.5 s), A = 2 spreads the clumps: 6.2% of the particles
// have a neighbour nearer than 0.6 d against 12.2% without (to 1 s: 8.6% against 15.8%).
TEST(ParticleShiftingTest, SpreadsTheClumpsOfADamBreak) {
  const double off = ClumpedFraction(DamScene(0), 0.5);
  const double on = ClumpedFraction(DamScene(2), 0.5);
  EXPECT_LT(on, 0.7 * off) << "clumped: " << on << " with shifting, " << off << " without";
}

}  // namespace
}  // namespace dysa
