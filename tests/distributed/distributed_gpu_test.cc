// GPU ranks on one process (SingleProcess), label gpu: DistributedSimulation with --device cuda:0
// (distributed_device_step.cc: the host's exchange, the upload in key order through page-locked
// buffers, the CUDA pipeline with the owned layers' maxima, the download, the order keys from
// the device's sort; dfsph's ghost-refresh hook and combined mean errors) gives, step by step,
// the state hash of the GPU's Simulation and of the CPU's. Skips, printing why, where cuda:0
// cannot run. On 2 and 3 MPI ranks sharing the GPU: mpi_gpu_ranks_test.sh (ctest -L gpu, -L
// mpi).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cinttypes>
#include <cstdio>
#include <string>

#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "dysa/distributed/distributed_simulation.h"
#include "support/gpu_test.h"

#if !defined(DYSA_RANKS_SCENE) || !defined(DYSA_RANKS_PERIODIC_SCENE) || \
    !defined(DYSA_RANKS_PC_SCENE) || !defined(DYSA_RANKS_SEED_SCENE) ||  \
    !defined(DYSA_RANKS_DFSPH_SCENE)
#error "tests/CMakeLists.txt defines DYSA_RANKS_SCENE and the other DYSA_RANKS_*_SCENE paths"
#endif

namespace dysa::distributed {
namespace {

using dysa::testing::kGpu;

// Frame by frame (each step capped at the frame's end, as `dysa run`), the hash of the GPU
// ranks' driver against the GPU's Simulation (the same device: must be equal) and the CPU's
// (equal where the GPU's solver is bit-identical to the CPU's, as on these scenes).
void ExpectSameBits(const Scene& scene, int frames, bool against_cpu) {
  const SingleProcess one;
  DistributedSimulation spread(scene, one, kGpu);
  Simulation gpu(scene, kGpu);
  Simulation cpu(scene);
  ASSERT_EQ(spread.TotalParticles(), gpu.particle_count());
  for (int f = 0; f < frames; ++f) {
    const double end = gpu.time() + gpu.model().FrameTime();
    while (gpu.time() < end && gpu.alarm().empty()) gpu.Step(end);
    while (cpu.time() < end && cpu.alarm().empty()) cpu.Step(end);
    while (spread.time() < end && spread.alarm().empty()) spread.Step(end);
    ASSERT_EQ(spread.alarm(), "");
    ASSERT_EQ(spread.step(), gpu.step()) << "frame " << f;
    const uint64_t hash = spread.GlobalStateHash();
    ASSERT_EQ(hash, StateHash(gpu.state())) << "frame " << f << ": GPU ranks against the GPU";
    if (against_cpu) {
      ASSERT_EQ(hash, StateHash(cpu.state())) << "frame " << f << ": GPU ranks against the CPU";
    }
  }
  std::printf("%s: %" PRIu64 " steps, hash %016" PRIx64 "\n", scene.name.c_str(), spread.step(),
              spread.GlobalStateHash());
  EXPECT_GT(spread.step(), 20u);
  // The profile: the exchange, the copies and the device's passes.
  ASSERT_GE(spread.profile().size(), 5u);
  EXPECT_EQ(spread.profile().front().name, "exchange");
  EXPECT_EQ(spread.profile()[1].name, "upload");
  EXPECT_EQ(spread.profile().back().name, "drop_ghosts");
}

TEST(DistributedGpuTest, TheDamBreakGivesTheBitsOfOneProcess) {
  SKIP_WITHOUT_GPU();
  ExpectSameBits(LoadScene(DYSA_RANKS_SCENE), 12, true);
}

TEST(DistributedGpuTest, ThePeriodicSlabAxisWithShiftingToo) {
  SKIP_WITHOUT_GPU();
  ExpectSameBits(LoadScene(DYSA_RANKS_PERIODIC_SCENE), 12, true);
}

TEST(DistributedGpuTest, ThePredictorCorrectorToo) {
  SKIP_WITHOUT_GPU();
  // Two sorts a step: the maxima by the first, owners and keys by the second, the half step's
  // move checked between them.
  ExpectSameBits(LoadScene(DYSA_RANKS_PC_SCENE), 12, true);
}

TEST(DistributedGpuTest, TheSeedToo) {
  SKIP_WITHOUT_GPU();
  // Sorted by its predicted positions, a fixed step: the owners from the predicted cells.
  ExpectSameBits(LoadScene(DYSA_RANKS_SEED_SCENE), 10, true);
}

TEST(DistributedGpuTest, DfsphToo) {
  SKIP_WITHOUT_GPU();
  // The solves' ghost refresh through the backend's hook (nothing to exchange on one process)
  // and their mean errors over the owned particles, combined over the processes.
  ExpectSameBits(LoadScene(DYSA_RANKS_DFSPH_SCENE), 20, true);
}

TEST(DistributedGpuTest, MovingObstaclesToo) {
  SKIP_WITHOUT_GPU();
  // Against the GPU's Simulation only: the CPU's agreement on this scene is not established.
  ExpectSameBits(dysa::testing::MovingDamScene("wcsph"), 8, false);
  Scene pc = dysa::testing::MovingDamScene("wcsph");
  SetParam(pc.params, "time_integration", 1);
  ExpectSameBits(pc, 8, false);
}

// A checkpoint of the GPU's Simulation restored on the GPU ranks steps on to its hash, and the
// solver's arrays (wcsph's carried density, dfsph's warm start) come back from the device.
void ExpectACheckpointToRestoreAndStepOn(const Scene& scene) {
  Simulation gpu(scene, kGpu);
  const double frame = gpu.model().FrameTime();
  for (int f = 0; f < 3; ++f) gpu.StepFrame();
  const SingleProcess one;
  DistributedSimulation spread(scene, one, kGpu);
  spread.RestoreCheckpoint(gpu.SaveCheckpoint());
  ASSERT_EQ(spread.GlobalStateHash(), StateHash(gpu.state()));
  const double end = gpu.time() + 2 * frame;
  while (gpu.time() < end) gpu.Step(end);
  while (spread.time() < end) spread.Step(end);
  EXPECT_EQ(spread.step(), gpu.step());
  EXPECT_EQ(spread.GlobalStateHash(), StateHash(gpu.state()));
  // The solver's arrays came back from the device with the particles.
  const Checkpoint a = gpu.SaveCheckpoint();
  const Checkpoint b = spread.SaveCheckpoint();
  ASSERT_EQ(b.solver_arrays.size(), a.solver_arrays.size());
  for (size_t k = 0; k < a.solver_arrays.size(); ++k) {
    EXPECT_TRUE(b.solver_arrays[k].values == a.solver_arrays[k].values) << a.solver_arrays[k].name;
  }
}

TEST(DistributedGpuTest, ACheckpointRestoresOnTheGpuRanksAndStepsOn) {
  SKIP_WITHOUT_GPU();
  ExpectACheckpointToRestoreAndStepOn(LoadScene(DYSA_RANKS_SCENE));
  ExpectACheckpointToRestoreAndStepOn(LoadScene(DYSA_RANKS_DFSPH_SCENE));
}

}  // namespace
}  // namespace dysa::distributed
