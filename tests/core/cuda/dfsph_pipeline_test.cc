// Tests of the dfsph solver's CUDA backend (server/core/src/cuda/dfsph_pipeline.cu) through
// Simulation: the GPU follows the CPU (kinetic energy, mean density, centre of mass, probes
// within stated tolerances after hundreds of steps), the solves report their iterations.
// Determinism and checkpoints (with the warm start) on the GPU: solver_conformance_gpu_test.
// ctest label `gpu`: the tests skip, printing why, where no CUDA GPU can run.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "dysa/core/simulation.h"
#include "support/gpu_test.h"

namespace dysa {
namespace {

using dysa::testing::DamScene;
using dysa::testing::ExpectAgreement;
using dysa::testing::kGpu;
using dysa::testing::MovingDamScene;
using dysa::testing::PeriodicScene;
using dysa::testing::WendlandDamScene;

const char* const kSolver = "dfsph";

// Every particle within 1 um of where the CPU has it (matched by id).
void ExpectSamePositions(const Simulation& cpu, const Simulation& gpu) {
  const ParticleArrays& pc = cpu.state().particles;
  const ParticleArrays& pg = gpu.state().particles;
  ASSERT_EQ(pg.size(), pc.size());
  std::vector<Vec3> by_id_cpu(pc.size()), by_id_gpu(pg.size());
  for (size_t i = 0; i < pc.size(); ++i) by_id_cpu[pc.id[i]] = pc.position[i];
  for (size_t i = 0; i < pg.size(); ++i) by_id_gpu[pg.id[i]] = pg.position[i];
  double worst = 0;
  for (size_t k = 0; k < pc.size(); ++k) {
    worst = std::max(worst, double((by_id_gpu[k] - by_id_cpu[k]).norm()));
  }
  EXPECT_LT(worst, 1e-6) << "m, the largest distance between a particle on the CPU and the GPU";
}

TEST(DfsphGpuTest, FollowsTheCpuThroughADamBreakPastObstacles) {
  SKIP_WITHOUT_GPU();
  ExpectAgreement(DamScene(kSolver), 0.3);
}

TEST(DfsphGpuTest, FollowsTheCpuAcrossPeriodicAxes) {
  SKIP_WITHOUT_GPU();
  ExpectAgreement(PeriodicScene(kSolver), 0.3);
}

TEST(DfsphGpuTest, TheFirstStepsMatchTheCpusSolves) {
  SKIP_WITHOUT_GPU();
  Simulation cpu(DamScene(kSolver));
  Simulation gpu(DamScene(kSolver), kGpu);
  EXPECT_EQ(gpu.PassNames(), cpu.PassNames());
  for (int i = 0; i < 5; ++i) {
    cpu.Step();
    gpu.Step();
    EXPECT_EQ(gpu.last_dt(), cpu.last_dt()) << "step " << i + 1;
    const SolverStats c = cpu.solver_stats();
    const SolverStats g = gpu.solver_stats();
    EXPECT_GE(g.density_iterations, 2);
    EXPECT_GE(g.divergence_iterations, 2);
    EXPECT_NEAR(g.density_iterations, c.density_iterations, 1) << "step " << i + 1;
    EXPECT_NEAR(g.divergence_iterations, c.divergence_iterations, 1) << "step " << i + 1;
  }
  ExpectSamePositions(cpu, gpu);
}

// Half-support cells (grid_cells_per_support 2): the same solves as the CPU's, step by step.
TEST(DfsphGpuTest, HalfSupportCellsMatchTheCpusSolves) {
  SKIP_WITHOUT_GPU();
  for (Scene scene : {DamScene(kSolver), PeriodicScene(kSolver)}) {
    scene.params.grid_cells_per_support = 2;
    Simulation cpu(scene);
    Simulation gpu(scene, kGpu);
    for (int i = 0; i < 5; ++i) {
      cpu.Step();
      gpu.Step();
      EXPECT_EQ(gpu.last_dt(), cpu.last_dt()) << scene.name << ", step " << i + 1;
      EXPECT_NEAR(gpu.solver_stats().density_iterations, cpu.solver_stats().density_iterations, 1);
    }
    ExpectSamePositions(cpu, gpu);
  }
}

// Signed corrections (signed_corrections 1) from all of the previous step's pressure: the first
// steps' time steps, iteration counts and positions as the CPU's, then the same run within the
// agreement's tolerances.
TEST(DfsphGpuTest, SignedCorrectionsFollowTheCpu) {
  SKIP_WITHOUT_GPU();
  Scene scene = DamScene(kSolver);
  scene.params.signed_corrections = 1;
  scene.params.warm_start = 1;
  Simulation cpu(scene);
  Simulation gpu(scene, kGpu);
  for (int i = 0; i < 5; ++i) {
    cpu.Step();
    gpu.Step();
    EXPECT_EQ(gpu.last_dt(), cpu.last_dt()) << "step " << i + 1;
    EXPECT_NEAR(gpu.solver_stats().density_iterations, cpu.solver_stats().density_iterations, 1)
        << "step " << i + 1;
  }
  ExpectSamePositions(cpu, gpu);
  ExpectAgreement(scene, 0.3);
}

// The Wendland kernel at a larger support (kernel and smoothing_length_ratio) on the GPU.
TEST(DfsphGpuTest, WendlandAtALargerSupportFollowsTheCpu) {
  SKIP_WITHOUT_GPU();
  ExpectAgreement(WendlandDamScene(kSolver), 0.2);
}

// Moving obstacles (the move_boundary pass, the samples' velocities in the density rate, the
// contact with moving surfaces, the CFL steps counting their speed): the same pass list, the
// first steps' time steps and positions as the CPU's, then the same run within the
// agreement's tolerances.
TEST(DfsphGpuTest, MovingObstaclesFollowTheCpu) {
  SKIP_WITHOUT_GPU();
  Simulation cpu(MovingDamScene(kSolver));
  Simulation gpu(MovingDamScene(kSolver), kGpu);
  ASSERT_EQ(gpu.PassNames().front(), "move_boundary");
  EXPECT_EQ(gpu.PassNames(), cpu.PassNames());
  for (int i = 0; i < 5; ++i) {
    cpu.Step();
    gpu.Step();
    EXPECT_EQ(gpu.last_dt(), cpu.last_dt()) << "step " << i + 1;
  }
  ExpectSamePositions(cpu, gpu);
  ExpectAgreement(MovingDamScene(kSolver), 0.3);
}

TEST(DfsphGpuTest, EveryPassIsTimed) {
  SKIP_WITHOUT_GPU();
  Simulation sim(DamScene(kSolver), kGpu);
  for (int i = 0; i < 4; ++i) sim.Step();
  for (const PassProfile& pass : sim.profile()) {
    EXPECT_EQ(pass.calls, 4u) << pass.name;
    EXPECT_GT(pass.total_ms, 0) << pass.name;
  }
}

}  // namespace
}  // namespace dysa
