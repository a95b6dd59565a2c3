// Tests of wcsph's continuity equation with its density diffusion (becker_teschner_solver.h):
// the diffusive term of Fourtakas et al. 2019 vanishes on a uniform and on a hydrostatic density
// field, exchanges density between pairs antisymmetrically (sum_i V_i D_i = 0), damps a
// perturbation; delta = 0 leaves only the velocity divergence; and the carried density goes
// into a checkpoint.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "solvers/wcsph/becker_teschner_solver.h"

namespace dysa {
namespace {

using wcsph::BeckerTeschnerData;

// Water at rest, 8 x 8 x 8 particles of 0.02 m in a closed box just large enough (its walls'
// boundary particles in reach of the outer layers), and its top 0.1 m of air.
Scene TankScene(double gravity, double delta) {
  Scene scene = ParseScene(R"({
    "domain": {"min": [0, 0, 0], "max": [0.16, 0.26, 0.16]},
    "fluid_blocks": [{"center": [0.08, 0.08, 0.08], "size": [0.16, 0.16, 0.16]}],
    "solver": "wcsph",
    "params": {"particle_spacing": 0.02, "speed_of_sound": 20, "kinematic_viscosity": 0}
  })");
  SetParam(scene.params, "gravity", gravity);
  SetParam(scene.params, "density_diffusion", delta);
  return scene;
}

// The rates D rho / Dt of the state of `sim` (velocities as they are) with densities
// density(x) instead of the carried ones, from the density pass run on a copy of the state.
template <class Field>
std::vector<Real> Rates(const Simulation& sim, Field density, State* out = nullptr) {
  State state = sim.state();
  BeckerTeschnerData data;
  data.SampleBoundary(sim.model());
  wcsph::SortIntoGrid(sim.model(), data, state);
  data.density.resize(state.particles.size());
  for (size_t i = 0; i < data.density.size(); ++i) {
    data.density[i] = Real(density(state.particles.position[i].template cast<double>()));
  }
  wcsph::ComputePressure(sim.model(), data, state);
  wcsph::ComputeBoundaryPressure(sim.model(), data, state);
  wcsph::ComputeInteractions(sim.model(), data, state);
  if (out) *out = state;
  return data.density_rate;
}

double MaxAbs(const std::vector<Real>& values) {
  double m = 0;
  for (Real v : values) m = std::max(m, std::abs(double(v)));
  return m;
}

// A density perturbation of 0.1% (a pressure of 2.8 kPa at c0 = 20 m/s), random per particle.
double Perturbed(const Vec3d& x) {
  const uint64_t seed = uint64_t(std::llround(x.x() * 1e4) * 73856093) ^
                        uint64_t(std::llround(x.y() * 1e4) * 19349663) ^
                        uint64_t(std::llround(x.z() * 1e4) * 83492791);
  std::mt19937_64 random(seed);
  return 1000 * (1 + 1e-3 * std::uniform_real_distribution<double>(-1, 1)(random));
}

TEST(DensityDiffusionTest, VanishesOnAUniformField) {
  const Simulation sim(TankScene(0, 0.1));
  // At rest: no divergence, and no density differences to diffuse, at the surface too.
  const std::vector<Real> rates = Rates(sim, [](const Vec3d&) { return 1000.0; });
  EXPECT_EQ(MaxAbs(rates), 0);
  // The same term on a perturbed field is far from 0.
  EXPECT_GT(MaxAbs(Rates(sim, Perturbed)), 1.0);
}

// rho = rho0 (1 + rho0 g (H - y) / (gamma B)) = rho0 + rho0 g (H - y) / c0^2: the hydrostatic
// density of the linearised Tait equation. Molteni & Colagrossi's term (Fourtakas's without its
// hydrostatic part: here with gravity 0) diffuses it towards uniform; Fourtakas's leaves it.
TEST(DensityDiffusionTest, VanishesOnAHydrostaticField) {
  const double g = 9.81, c0 = 20, H = 0.16;
  const auto hydrostatic = [&](const Vec3d& x) { return 1000 * (1 + g * (H - x.y()) / (c0 * c0)); };
  const double fourtakas = MaxAbs(Rates(Simulation(TankScene(-g, 0.1)), hydrostatic));
  const double molteni = MaxAbs(Rates(Simulation(TankScene(0, 0.1)), hydrostatic));
  EXPECT_GT(molteni, 1.0);  // kg/m^3/s: the column would lose its hydrostatic density
  EXPECT_LT(fourtakas, 1e-3 * molteni);
}

TEST(DensityDiffusionTest, ExchangesDensityBetweenPairsAntisymmetrically) {
  const Simulation sim(TankScene(-9.81, 0.1));
  State state;
  const std::vector<Real> rates = Rates(sim, Perturbed, &state);
  // sum_i V_i D_i = sum_ij V_i V_j psi_ij . grad W_ij, each pair twice with opposite signs.
  double sum = 0, magnitude = 0;
  for (size_t i = 0; i < rates.size(); ++i) {
    const double volume =
        sim.model().particle_mass / Perturbed(state.particles.position[i].cast<double>());
    sum += volume * rates[i];
    magnitude += volume * std::abs(rates[i]);
  }
  EXPECT_GT(magnitude, 0);
  EXPECT_LT(std::abs(sum), 1e-5 * magnitude);
}

TEST(DensityDiffusionTest, DampsAPerturbationAndScalesWithDelta) {
  State state;
  const std::vector<Real> rates = Rates(Simulation(TankScene(0, 0.1)), Perturbed, &state);
  // d/dt sum_i V_i (rho_i - rho0)^2 / 2 = sum_i V_i (rho_i - rho0) D_i < 0: the perturbation
  // decays; and every particle's rate is towards its neighbours' mean, for a spike alone.
  double decay = 0;
  for (size_t i = 0; i < rates.size(); ++i) {
    const double rho = Perturbed(state.particles.position[i].cast<double>());
    decay += (rho - 1000) * rates[i] / rho;
  }
  EXPECT_LT(decay, 0);
  const Vec3d centre(0.09, 0.09, 0.09);  // a particle's centre, inside
  const auto spike = [&](const Vec3d& x) { return (x - centre).norm() < 1e-4 ? 1001.0 : 1000.0; };
  const std::vector<Real> spiked = Rates(Simulation(TankScene(0, 0.1)), spike, &state);
  int at_spike = 0;
  for (size_t i = 0; i < spiked.size(); ++i) {
    const double r = (state.particles.position[i].cast<double>() - centre).norm();
    if (r < 1e-4) {
      EXPECT_LT(spiked[i], 0);
      ++at_spike;
    } else if (r < 0.039) {
      EXPECT_GT(spiked[i], 0) << r;  // within the support (0.04): receives
    } else if (r > 0.041) {
      EXPECT_EQ(spiked[i], 0) << r;
    }
  }
  EXPECT_EQ(at_spike, 1);
  // The term is linear in delta, and 0 with it (at rest nothing else changes the density).
  const std::vector<Real> doubled = Rates(Simulation(TankScene(0, 0.2)), Perturbed);
  for (size_t i = 0; i < rates.size(); ++i)
    EXPECT_NEAR(doubled[i], 2 * rates[i], 1e-3 * MaxAbs(rates));
  EXPECT_EQ(MaxAbs(Rates(Simulation(TankScene(0, 0)), Perturbed)), 0);
}

// Without diffusion, D rho / Dt is the time derivative of the summation density
// sum_j m W_ij + sum_b Psi_b W_ib: a rigid translation of the fluid away from the walls
// changes only the outer particles' (their wall neighbours fall behind), the inner ones not.
TEST(DensityDiffusionTest, ContinuityFollowsTheRelativeMotionOnly) {
  Simulation sim(TankScene(0, 0));
  Checkpoint moving = sim.SaveCheckpoint();
  for (Vec3& v : moving.velocity) v = Vec3(0.5f, 0, 0);
  sim.RestoreCheckpoint(moving);
  State state;
  const std::vector<Real> rates = Rates(
      sim, [](const Vec3d&) { return 1000.0; }, &state);
  double outer = 0, inner = 0;
  for (size_t i = 0; i < rates.size(); ++i) {
    const double x = state.particles.position[i].x();
    double& side = x > 0.04 && x < 0.12 ? inner : outer;
    side = std::max(side, std::abs(double(rates[i])));
  }
  EXPECT_GT(outer, 100);           // kg/m^3/s: leaving the wall x = 0, nearing x = 0.16
  EXPECT_LT(inner, 1e-4 * outer);  // the floor's and the side walls' terms cancel across x
}

TEST(DensityDiffusionTest, TheCarriedDensityIsInTheCheckpoint) {
  Simulation sim(TankScene(-9.81, 0.1));
  for (int i = 0; i < 20; ++i) sim.Step();
  const Checkpoint checkpoint = sim.SaveCheckpoint();
  ASSERT_EQ(checkpoint.solver_arrays.size(), 1u);
  EXPECT_EQ(checkpoint.solver_arrays[0].name, wcsph::kCarriedDensity);
  ASSERT_EQ(checkpoint.solver_arrays[0].values.size(), sim.particle_count());
  // Under gravity the column has compressed: the carried density is no longer rho0.
  const std::vector<Real>& rho = checkpoint.solver_arrays[0].values;
  EXPECT_GT(*std::max_element(rho.begin(), rho.end()), 1000.5f);
  auto steps_from = [&](const Checkpoint& start) {
    sim.RestoreCheckpoint(start);
    for (int i = 0; i < 5; ++i) sim.Step();
    return StateHash(sim.state());
  };
  const uint64_t carried = steps_from(checkpoint);
  Checkpoint without = checkpoint;
  without.solver_arrays.clear();  // restarts from max(summation density, rho0)
  EXPECT_NE(steps_from(without), carried);
  EXPECT_EQ(steps_from(checkpoint), carried);
}

}  // namespace
}  // namespace dysa
