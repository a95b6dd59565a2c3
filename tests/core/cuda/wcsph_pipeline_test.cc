// Tests of the wcsph solver's CUDA backend (server/core/src/cuda/wcsph_pipeline.cu) through
// Simulation: the GPU follows the CPU (kinetic energy, mean density, centre of mass, probes
// within stated tolerances after hundreds of steps, the same adaptive steps). Determinism and
// checkpoints on the GPU: solver_conformance_gpu_test. ctest label `gpu`: the tests skip,
// printing why, where no CUDA GPU can run.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "dysa/core/simulation.h"
#include "support/gpu_test.h"

namespace dysa {
namespace {

using dysa::testing::DamScene;
using dysa::testing::ExpectAgreement;
using dysa::testing::kGpu;
using dysa::testing::MovingDamScene;
using dysa::testing::PeriodicScene;
using dysa::testing::SplittingBlocksScene;
using dysa::testing::WendlandDamScene;

const char* const kSolver = "wcsph";

// Steps `cpu` and `gpu` `steps` times, expecting the same dt at every step.
void StepBoth(Simulation& cpu, Simulation& gpu, int steps) {
  for (int i = 0; i < steps; ++i) {
    cpu.Step();
    gpu.Step();
    EXPECT_EQ(gpu.last_dt(), cpu.last_dt()) << "step " << i + 1;
  }
}

TEST(WcsphGpuTest, FollowsTheCpuThroughADamBreakPastObstacles) {
  SKIP_WITHOUT_GPU();
  ExpectAgreement(DamScene(kSolver), 0.3);
}

TEST(WcsphGpuTest, FollowsTheCpuAcrossPeriodicAxes) {
  SKIP_WITHOUT_GPU();
  ExpectAgreement(PeriodicScene(kSolver), 0.3);
}

TEST(WcsphGpuTest, TheFirstStepsAreBitIdenticalToTheCpu) {
  SKIP_WITHOUT_GPU();
  // Before any rounding of pow() can differ and grow: the first 5 steps of the dam.
  Simulation cpu(DamScene(kSolver));
  Simulation gpu(DamScene(kSolver), kGpu);
  EXPECT_EQ(gpu.PassNames(), cpu.PassNames());
  StepBoth(cpu, gpu, 5);
  EXPECT_EQ(StateHash(gpu.state()), StateHash(cpu.state()));
}

// The Wendland kernel at a larger support, chosen at run time, is the same arithmetic on both
// devices: bit-identical first steps, then the run within the agreement's tolerances.
TEST(WcsphGpuTest, WendlandAtALargerSupportIsBitIdenticalToTheCpu) {
  SKIP_WITHOUT_GPU();
  Simulation cpu(WendlandDamScene(kSolver));
  Simulation gpu(WendlandDamScene(kSolver), kGpu);
  StepBoth(cpu, gpu, 5);
  EXPECT_EQ(StateHash(gpu.state()), StateHash(cpu.state()));
  ExpectAgreement(WendlandDamScene(kSolver), 0.2);
}

// Half-support cells (grid_cells_per_support 2): the same candidates in the same order as the
// CPU's grid, with walls and across periodic seams (the 5x5x5 block wraps as one run): the
// first steps bit-identical.
TEST(WcsphGpuTest, HalfSupportCellsAreBitIdenticalToTheCpu) {
  SKIP_WITHOUT_GPU();
  for (Scene scene : {DamScene(kSolver), PeriodicScene(kSolver), WendlandDamScene(kSolver)}) {
    scene.params.grid_cells_per_support = 2;
    Simulation cpu(scene);
    Simulation gpu(scene, kGpu);
    StepBoth(cpu, gpu, 5);
    EXPECT_EQ(StateHash(gpu.state()), StateHash(cpu.state())) << scene.name;
  }
}

// The continuity equation's density (with its diffusion) is carried on the GPU as on the CPU,
// and a checkpoint holds it under the CPU's name: after the first, bit-identical, steps the
// two carry the same value for every particle.
TEST(WcsphGpuTest, CarriesTheDensityAsTheCpuDoes) {
  SKIP_WITHOUT_GPU();
  Simulation cpu(DamScene(kSolver));
  Simulation gpu(DamScene(kSolver), kGpu);
  for (int i = 0; i < 5; ++i) cpu.Step(), gpu.Step();
  const Checkpoint c = cpu.SaveCheckpoint();
  const Checkpoint g = gpu.SaveCheckpoint();
  ASSERT_EQ(g.solver_arrays.size(), 1u);
  ASSERT_EQ(c.solver_arrays.size(), 1u);
  EXPECT_EQ(g.solver_arrays[0].name, c.solver_arrays[0].name);
  ASSERT_EQ(g.solver_arrays[0].values.size(), g.id.size());
  std::map<uint32_t, Real> by_id;
  for (size_t k = 0; k < c.id.size(); ++k) by_id[c.id[k]] = c.solver_arrays[0].values[k];
  for (size_t k = 0; k < g.id.size(); ++k) {
    EXPECT_EQ(g.solver_arrays[0].values[k], by_id.at(g.id[k])) << "particle " << g.id[k];
  }
  const std::vector<Real>& rho = g.solver_arrays[0].values;
  EXPECT_GT(*std::max_element(rho.begin(), rho.end()), 1000.0f);  // compressed under gravity
}

// Moving obstacles (the move_boundary pass, the samples' velocities in the continuity
// equation, the contact with moving surfaces, the CFL step counting their speed): the same
// pass list and the first steps bit for bit, then the same run within the agreement's
// tolerances.
TEST(WcsphGpuTest, MovingObstaclesFollowTheCpu) {
  SKIP_WITHOUT_GPU();
  Simulation cpu(MovingDamScene(kSolver));
  Simulation gpu(MovingDamScene(kSolver), kGpu);
  ASSERT_EQ(gpu.PassNames().front(), "move_boundary");
  EXPECT_EQ(gpu.PassNames(), cpu.PassNames());
  StepBoth(cpu, gpu, 5);
  EXPECT_EQ(StateHash(gpu.state()), StateHash(cpu.state()));
  ExpectAgreement(MovingDamScene(kSolver), 0.3);
}

// The predictor-corrector (time_integration = 1, symplectic.h) on both devices: the same pass
// list, the first steps bit for bit (the moving obstacles placed at the half step, the contact's
// surfaces over each half), then the same run within the agreement's tolerances.
TEST(WcsphGpuTest, SymplecticIsBitIdenticalToTheCpu) {
  SKIP_WITHOUT_GPU();
  Scene scene = MovingDamScene(kSolver);
  SetParam(scene.params, "time_integration", 1);
  Simulation cpu(scene);
  Simulation gpu(scene, kGpu);
  EXPECT_EQ(gpu.PassNames(), cpu.PassNames());
  StepBoth(cpu, gpu, 5);
  EXPECT_EQ(StateHash(gpu.state()), StateHash(cpu.state()));
  ExpectAgreement(scene, 0.3);
}

// Particle shifting (particle_shifting.h) on both devices, with either integration: the same
// pass list and the first steps bit for bit.
TEST(WcsphGpuTest, ParticleShiftingIsBitIdenticalToTheCpu) {
  SKIP_WITHOUT_GPU();
  for (const int integration : {0, 1}) {
    SCOPED_TRACE(integration);
    Scene scene = MovingDamScene(kSolver);
    SetParam(scene.params, "particle_shifting", 2);
    SetParam(scene.params, "time_integration", integration);
    Simulation cpu(scene);
    Simulation gpu(scene, kGpu);
    EXPECT_EQ(gpu.PassNames(), cpu.PassNames());
    for (int i = 0; i < 5; ++i) {
      cpu.Step();
      gpu.Step();
    }
    EXPECT_EQ(StateHash(gpu.state()), StateHash(cpu.state()));
  }
}

// Monaghan's artificial viscosity (artificial_viscosity > 0; its fluid pairs and the no-slip
// floor's boundary particles, with and without the laminar viscosity, which otherwise alone has
// the floor's mirrored velocity extrapolated) on both devices, with either integration: the same
// pass list and the first steps bit for bit, the term acting (the state is not alpha = 0's),
// then the same run within the agreement's tolerances.
TEST(WcsphGpuTest, ArtificialViscosityIsBitIdenticalToTheCpu) {
  SKIP_WITHOUT_GPU();
  struct Case {
    int integration;
    double nu;
  };
  for (const Case& c : {Case{0, 1e-5}, Case{1, 1e-5}, Case{0, 0}}) {
    SCOPED_TRACE(std::to_string(c.integration) + ", nu " + std::to_string(c.nu));
    Scene scene = MovingDamScene(kSolver);
    SetParam(scene.params, "time_integration", c.integration);
    SetParam(scene.params, "kinematic_viscosity", c.nu);
    Simulation plain(scene);
    SetParam(scene.params, "artificial_viscosity", 0.05);
    Simulation cpu(scene);
    Simulation gpu(scene, kGpu);
    EXPECT_EQ(gpu.PassNames(), cpu.PassNames());
    StepBoth(cpu, gpu, 5);
    for (int i = 0; i < 5; ++i) plain.Step();
    EXPECT_EQ(StateHash(gpu.state()), StateHash(cpu.state()));
    EXPECT_NE(StateHash(cpu.state()), StateHash(plain.state()));
  }
  Scene scene = MovingDamScene(kSolver);
  SetParam(scene.params, "artificial_viscosity", 0.05);
  ExpectAgreement(scene, 0.3);
}

// The carried density's range (carried_density_min, kCarriedDensityMax) on the device: two
// blocks thrown apart reach both bounds and stay within them, on either integration, the first
// steps bit for bit with the CPU.
TEST(WcsphGpuTest, HoldsTheCarriedDensityInItsRangeAsTheCpuDoes) {
  SKIP_WITHOUT_GPU();
  for (const int integration : {0, 1}) {
    SCOPED_TRACE(integration);
    Scene scene = SplittingBlocksScene(kSolver);
    SetParam(scene.params, "time_integration", integration);
    Simulation cpu(scene);
    Simulation gpu(scene, kGpu);
    for (int i = 0; i < 5; ++i) {
      cpu.Step();
      gpu.Step();
    }
    EXPECT_EQ(StateHash(gpu.state()), StateHash(cpu.state()));
    float lowest = 1000, highest = 1000;
    for (int i = 0; i < 145; ++i) {
      gpu.Step();
      for (const float rho : gpu.state().particles.density) {
        ASSERT_TRUE(std::isfinite(rho)) << "step " << i + 6;
        lowest = std::min(lowest, rho);
        highest = std::max(highest, rho);
      }
    }
    EXPECT_EQ(lowest, 700.0f);
    EXPECT_EQ(highest, 1300.0f);
  }
}

// carried_density_min = 1 on the device: the same blocks never carry less than rho0, and 30
// steps end bit for bit with the CPU's.
TEST(WcsphGpuTest, HoldsTheCarriedDensityAtRho0AsTheCpuDoes) {
  SKIP_WITHOUT_GPU();
  Scene scene = SplittingBlocksScene(kSolver);
  SetParam(scene.params, "carried_density_min", 1.0);
  Simulation cpu(scene);
  Simulation gpu(scene, kGpu);
  for (int i = 0; i < 30; ++i) {
    cpu.Step();
    gpu.Step();
  }
  EXPECT_EQ(StateHash(gpu.state()), StateHash(cpu.state()));
  for (const float rho : gpu.state().particles.density) ASSERT_GE(rho, 1000.0f);
}

TEST(WcsphGpuTest, EveryPassIsTimed) {
  SKIP_WITHOUT_GPU();
  for (const int integration : {0, 1}) {
    SCOPED_TRACE(integration);
    Scene scene = DamScene(kSolver);
    SetParam(scene.params, "time_integration", integration);
    SetParam(scene.params, "particle_shifting", 2);
    Simulation sim(scene, kGpu);
    for (int i = 0; i < 4; ++i) sim.Step();
    for (const PassProfile& pass : sim.profile()) {
      EXPECT_EQ(pass.calls, 4u) << pass.name;
      EXPECT_GT(pass.total_ms, 0) << pass.name;
    }
  }
}

}  // namespace
}  // namespace dysa
