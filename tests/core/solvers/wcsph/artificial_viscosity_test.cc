// Tests of wcsph's artificial viscosity (Monaghan 1992; artificial_viscosity,
// becker_teschner_solver.h): the parameter's range; the term of Monaghan's formula between an
// approaching pair, opposite on the two particles, nothing between separating ones (a separating
// flow steps bit for bit as with alpha = 0); momentum conserved; the no-slip walls' boundary
// particles taking part, the free-slip ones not; a lattice's velocity noise damped, with either
// time integration.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <functional>
#include <random>
#include <string>

#include "dysa/core/params.h"
#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "solvers/wcsph/becker_teschner_solver.h"
#include "sph_loops.h"

namespace dysa {
namespace {

using ::testing::HasSubstr;
using wcsph::BeckerTeschnerData;

constexpr double kSpacing = 0.02;  // m
constexpr double kC0 = 20;         // m/s

// Fluid in a closed box of edge `box` (m) without gravity or laminar viscosity (so that only the
// pressure and the artificial viscosity act), the blocks' JSON given.
Scene BoxScene(const std::string& blocks, double alpha, int integration = 0, double box = 0.4) {
  const std::string edge = std::to_string(box);
  Scene scene = ParseScene(R"({
    "domain": {"min": [0, 0, 0], "max": [)" +
                           edge + ", " + edge + ", " + edge + R"(]},
    "fluid_blocks": [)" + blocks +
                           R"(],
    "solver": "wcsph",
    "params": {"gravity": 0, "particle_spacing": 0.02, "speed_of_sound": 20,
               "kinematic_viscosity": 0}
  })");
  SetParam(scene.params, "artificial_viscosity", alpha);
  SetParam(scene.params, "time_integration", integration);
  return scene;
}

// Two particles 1.5 d apart along x in the middle of the box, out of the walls' reach, moving
// at +u and -u (u > 0: towards each other).
Scene PairScene(double u, double alpha) {
  const std::string block = R"({"size": [0.02, 0.02, 0.02], "center": [)";
  return BoxScene(block + "0.2, 0.2, 0.2], \"velocity\": [" + std::to_string(u) + ", 0, 0]}, " +
                      block + "0.23, 0.2, 0.2], \"velocity\": [" + std::to_string(-u) + ", 0, 0]}",
                  alpha);
}

// A block of 6 x 6 x 6 particles in the middle of the box, out of the walls' reach.
Scene BlockScene(double alpha, int integration = 0) {
  return BoxScene(R"({"center": [0.2, 0.2, 0.2], "size": [0.12, 0.12, 0.12]})", alpha, integration);
}

// `sim` with each particle's velocity velocity(id, x) (its own parameters kept).
void SetVelocities(Simulation& sim, const std::function<Vec3(uint32_t, const Vec3&)>& velocity) {
  Checkpoint c = sim.SaveCheckpoint();
  for (size_t k = 0; k < c.id.size(); ++k) c.velocity[k] = velocity(c.id[k], c.position[k]);
  sim.RestoreCheckpoint(c);
}

// A velocity of up to `amplitude` m/s per component, random per particle id.
Vec3 Noise(uint32_t id, double amplitude) {
  std::mt19937 random(id * 2654435761u + 17);
  std::uniform_real_distribution<float> u(-float(amplitude), float(amplitude));
  const float x = u(random), y = u(random), z = u(random);
  return Vec3(x, y, z);
}

// The accelerations one step of `sim` would start from (the force passes on a copy of its
// state), in the grid's order, and that state; every carried density `density` (kg/m^3) when
// above 0, else the solver's start (max(summation density, rho0)).
std::vector<Vec3> Accelerations(const Simulation& sim, State* out = nullptr, double density = 0) {
  State state = sim.state();
  BeckerTeschnerData data;
  data.SampleBoundary(sim.model());
  wcsph::SortIntoGrid(sim.model(), data, state);
  if (density > 0) data.density.assign(state.particles.size(), Real(density));
  wcsph::ComputePressure(sim.model(), data, state);
  wcsph::ComputeBoundaryPressure(sim.model(), data, state);
  wcsph::ComputeInteractions(sim.model(), data, state);
  if (out) *out = state;
  return data.acceleration;
}

double KineticEnergy(const Simulation& sim) {
  double sum = 0;
  for (const Vec3& v : sim.state().particles.velocity) sum += v.cast<double>().squaredNorm();
  return 0.5 * sim.model().particle_mass * sum;
}

TEST(ArtificialViscosityTest, RangeErrorsNameTheFieldAndTheRange) {
  const ParamDecl* decl = FindParam("artificial_viscosity");
  ASSERT_NE(decl, nullptr);
  EXPECT_EQ(decl->DefaultValue(), 0);  // off unless a scene asks for it
  EXPECT_EQ(decl->RangeText(), "[0, 1]");
  EXPECT_FALSE(decl->needs_reset);  // live, as kinematic_viscosity
  EXPECT_EQ(decl->SolversText(), "wcsph");
  EXPECT_THAT(std::string(decl->description), HasSubstr("Monaghan"));
  for (const double bad : {-0.01, 1.5}) {
    Params params;
    try {
      SetParam(params, "artificial_viscosity", bad);
      ADD_FAILURE() << bad << " accepted";
    } catch (const ConfigError& e) {
      EXPECT_EQ(e.field(), "artificial_viscosity");
      EXPECT_THAT(e.message(), HasSubstr("outside the allowed range [0, 1]"));
    }
    EXPECT_EQ(params.artificial_viscosity, 0);
  }
  try {
    ParseScene(R"({"solver": "wcsph", "params": {"artificial_viscosity": 2}})");
    ADD_FAILURE() << "2 accepted";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.field(), "params.artificial_viscosity");
    EXPECT_THAT(e.what(), HasSubstr("[0, 1]"));
  }
}

// Two particles approaching at 1 m/s: with alpha = 0 nothing acts on them (no gravity, no
// laminar viscosity, the density rho0 and so no pressure); with alpha = 0.1 each is slowed by
// 2 alpha c0 h m (v_ij . x_ij) / ((rho_i + rho_j) (r^2 + 0.01 h^2)) grad W_ij (h = d), the other
// by exactly the opposite. Separating, they get nothing: the same bits as with alpha = 0.
TEST(ArtificialViscosityTest, SlowsAnApproachingPairByMonaghansTerm) {
  const Simulation off(PairScene(0.5, 0));
  const Simulation on(PairScene(0.5, 0.1));
  State state;
  const std::vector<Vec3> a0 = Accelerations(off);
  const std::vector<Vec3> a = Accelerations(on, &state);
  ASSERT_EQ(a.size(), 2u);
  EXPECT_EQ(a0[0], Vec3::Zero());
  EXPECT_EQ(a0[1], Vec3::Zero());
  const int left = state.particles.position[0].x() < state.particles.position[1].x() ? 0 : 1;
  const Vec3 xij = state.particles.position[left] - state.particles.position[1 - left];
  const Real r = xij.norm();
  EXPECT_NEAR(r, 1.5 * kSpacing, 1e-6);
  const double h = on.model().SmoothingLength();
  EXPECT_DOUBLE_EQ(h, kSpacing);
  const double vx = 1.0 * xij.x();  // v_ij = (1, 0, 0): approaching, v_ij . x_ij < 0
  const Vec3 grad = GradW(xij, r, on.model().Kernel());
  const double expected = 2 * 0.1 * kC0 * h * on.model().particle_mass * vx /
                          (2000 * (double(r) * r + 0.01 * h * h)) * grad.x();
  EXPECT_LT(expected, -1.0);  // m/s^2, against the left particle's motion
  EXPECT_NEAR(a[left].x(), expected, 1e-5 * std::abs(expected));
  EXPECT_EQ(a[left].y(), 0);
  EXPECT_EQ(a[left].z(), 0);
  EXPECT_EQ(a[1 - left], Vec3(-a[left]));  // opposite, to the bit

  const std::vector<Vec3> apart0 = Accelerations(Simulation(PairScene(-0.5, 0)));
  const std::vector<Vec3> apart = Accelerations(Simulation(PairScene(-0.5, 0.1)));
  EXPECT_EQ(apart, apart0);
  EXPECT_EQ(apart[0], Vec3::Zero());
}

// The two particles of the pair run into each other and bounce off (their pressure): with
// alpha = 0.1 they approach more slowly, by 7% at 5 ms, and leave more slowly, having lost
// energy; their total momentum stays 0.
TEST(ArtificialViscosityTest, DeceleratesApproachingParticlesMore) {
  // v_left - v_right at time t: > 0 approaching
  auto closing_speed = [](double alpha, double t) {
    Simulation sim(PairScene(0.5, alpha));
    while (sim.time() < t) sim.Step();
    const ParticleArrays& p = sim.state().particles;
    const int left = p.position[0].x() < p.position[1].x() ? 0 : 1;
    EXPECT_NEAR(p.velocity[0].x() + p.velocity[1].x(), 0, 1e-6);
    return double(p.velocity[left].x() - p.velocity[1 - left].x());
  };
  const double approaching = closing_speed(0, 0.005);
  EXPECT_GT(approaching, 0.5);  // m/s, of 1
  EXPECT_LT(closing_speed(0.1, 0.005), 0.95 * approaching);
  const double leaving = closing_speed(0, 0.01);
  EXPECT_LT(leaving, -0.5);  // bounced
  EXPECT_LT(leaving, closing_speed(0.1, 0.01));
}

// A block whose every pair separates (v = k (x - c), k > 0) steps bit for bit as with alpha = 0,
// with either time integration; contracting (k < 0), it does not.
TEST(ArtificialViscosityTest, LeavesASeparatingFlowBitForBit) {
  for (const int integration : {0, 1}) {
    SCOPED_TRACE(integration);
    auto run = [&](double alpha, float k) {
      Simulation sim(BlockScene(alpha, integration));
      SetVelocities(sim,
                    [&](uint32_t, const Vec3& x) { return Vec3(k * (x - Vec3::Constant(0.2f))); });
      for (int i = 0; i < 10; ++i) sim.Step();
      return StateHash(sim.state());
    };
    EXPECT_EQ(run(0.05, 2), run(0, 2));
    EXPECT_NE(run(0.05, -2), run(0, -2));
  }
}

// sum_i m a_i = 0 to round-off on a block with random velocities (every density rho0: no
// pressure, only the artificial viscosity acts), each pair's forces being opposite.
TEST(ArtificialViscosityTest, ConservesMomentum) {
  Simulation sim(BlockScene(0.05));
  SetVelocities(sim, [](uint32_t id, const Vec3&) { return Noise(id, 0.1); });
  const std::vector<Vec3> a = Accelerations(sim, nullptr, 1000);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double magnitude = 0;
  for (const Vec3& ai : a) {
    sum += ai.cast<double>();
    magnitude += ai.cast<double>().norm();
  }
  EXPECT_GT(magnitude / double(a.size()), 1.0);  // m/s^2: the term acts
  EXPECT_LT(sum.norm(), 1e-6 * magnitude);
  // Without it nothing acts at all.
  sim.SetParam("artificial_viscosity", 0.0);
  for (const Vec3& ai : Accelerations(sim, nullptr, 1000)) EXPECT_EQ(ai, Vec3::Zero());
}

// The no-slip walls' boundary particles take part with the fluid's mirrored velocity, as in the
// laminar wall term; free-slip walls do not: a particle falling onto a no-slip floor is slowed,
// onto a free-slip one it meets the same force as without the term.
TEST(ArtificialViscosityTest, ActsAtNoSlipWallsOnly) {
  auto floor_acceleration = [](bool no_slip, double alpha) {
    Scene scene = BoxScene(R"({"center": [0.2, 0.01, 0.2], "size": [0.02, 0.02, 0.02],
                               "velocity": [0, -0.5, 0]})",
                           alpha);
    scene.no_slip = {false, no_slip, false};
    const std::vector<Vec3> a = Accelerations(Simulation(scene), nullptr, 1000);
    return a.at(0).y();
  };
  // No pressure (rho0), no gravity, no laminar viscosity: nothing else acts.
  EXPECT_EQ(floor_acceleration(false, 0), 0);
  EXPECT_EQ(floor_acceleration(true, 0), 0);
  EXPECT_EQ(floor_acceleration(false, 0.1), 0);
  EXPECT_GT(floor_acceleration(true, 0.1), 10);  // m/s^2, up (31.5)
}

// A lattice with random velocities and no gravity in a closed box: the velocity noise turns into
// pressure waves that only the density diffusion damps with alpha = 0, and it decays faster with
// alpha = 0.05, with either time integration.
TEST(ArtificialViscosityTest, DampsALatticesVelocityNoise) {
  for (const int integration : {0, 1}) {
    SCOPED_TRACE(integration);
    auto energy_after = [&](double alpha, double& start) {
      // 10 x 10 x 10 particles filling a 0.2 m box
      Scene scene = BoxScene(R"({"center": [0.1, 0.1, 0.1], "size": [0.2, 0.2, 0.2]})", alpha,
                             integration, 0.2);
      Simulation sim(scene);
      SetVelocities(sim, [](uint32_t id, const Vec3&) { return Noise(id, 0.2); });
      start = KineticEnergy(sim);
      while (sim.time() < 0.02) sim.Step();
      EXPECT_EQ(sim.alarm(), "");
      return KineticEnergy(sim);
    };
    double start0 = 0, start = 0;
    const double without = energy_after(0, start0), with = energy_after(0.05, start);
    EXPECT_EQ(start, start0);
    std::printf("kinetic energy after 0.02 s: %.3g (alpha 0), %.3g (alpha 0.05) of %.3g J\n",
                without, with, start);
    EXPECT_LT(with, 0.8 * without);  // 0.68 times
  }
}

}  // namespace
}  // namespace dysa
