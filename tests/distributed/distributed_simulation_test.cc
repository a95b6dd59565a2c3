// Tests of server/distributed/src/distributed_simulation.cc on one process (SingleProcess):
// its steps, driven by the order keys of particle_exchange.h rather than by the storage order,
// give the bits of dysa::Simulation (wcsph, the seed, dfsph); a solver not made to run across
// processes is refused by name. The same on 2 and 3 MPI ranks: mpi_ranks_test.sh (ctest -L mpi).
#include "dysa/distributed/distributed_simulation.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <memory>
#include <string>

#include "distributed/host_device_backend.h"
#include "dysa/core/device.h"
#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "dysa/core/types.h"
#include "dysa/distributed/rank_device.h"

#if !defined(DYSA_RANKS_SCENE) || !defined(DYSA_RANKS_SEED_SCENE) || \
    !defined(DYSA_RANKS_DFSPH_SCENE)
#error "tests/CMakeLists.txt defines DYSA_RANKS_SCENE, _SEED_SCENE and _DFSPH_SCENE"
#endif

namespace dysa::distributed {
namespace {

using ::testing::HasSubstr;

// Both step to the same caps (the end of each frame), as `dysa run` does.
void ExpectSameBits(const Scene& scene, int frames) {
  const SingleProcess one;
  DistributedSimulation spread(scene, one);
  Simulation plain(scene);
  ASSERT_EQ(spread.TotalParticles(), plain.particle_count());
  for (int f = 0; f < frames; ++f) {
    const double end = plain.time() + plain.model().FrameTime();
    while (plain.time() < end) plain.Step(end);
    while (spread.time() < end) spread.Step(end);
    ASSERT_EQ(spread.step(), plain.step()) << "frame " << f;
    ASSERT_EQ(spread.GlobalStateHash(), StateHash(plain.state())) << "frame " << f;
  }
  EXPECT_TRUE(spread.alarm().empty()) << spread.alarm();
  EXPECT_GT(plain.step(), 20u);
}

// Steps `sim` (Simulation or DistributedSimulation) through `frames` frames, each step capped at
// the frame's end.
template <class Sim>
void StepFrames(Sim& sim, double frame_time, int frames) {
  for (int f = 0; f < frames; ++f) {
    const double end = sim.time() + frame_time;
    while (sim.time() < end) sim.Step(end);
  }
}

TEST(DistributedSimulationTest, ACheckpointIsTheOneOfSimulation) {
  const Scene scene = LoadScene(DYSA_RANKS_SCENE);
  const SingleProcess one;
  DistributedSimulation spread(scene, one);
  Simulation plain(scene);
  const double frame = plain.model().FrameTime();
  StepFrames(plain, frame, 2);
  StepFrames(spread, frame, 2);
  const Checkpoint a = plain.SaveCheckpoint();
  const Checkpoint b = spread.SaveCheckpoint();
  EXPECT_EQ(b.time, a.time);
  EXPECT_EQ(b.step, a.step);
  EXPECT_EQ(b.id, a.id);
  EXPECT_TRUE(b.position == a.position);
  EXPECT_TRUE(b.velocity == a.velocity);
  ASSERT_EQ(b.solver_arrays.size(), a.solver_arrays.size());
  for (size_t k = 0; k < a.solver_arrays.size(); ++k) {
    EXPECT_EQ(b.solver_arrays[k].name, a.solver_arrays[k].name);
    EXPECT_EQ(b.solver_arrays[k].values, a.solver_arrays[k].values);
    EXPECT_EQ(a.solver_arrays[k].values.size(), a.id.size());  // wcsph's carried density
  }
}

TEST(DistributedSimulationTest, ACheckpointOfSimulationRestoresAndStepsOnBitForBit) {
  const Scene scene = LoadScene(DYSA_RANKS_SCENE);
  Simulation plain(scene);
  const double frame = plain.model().FrameTime();
  StepFrames(plain, frame, 2);
  Checkpoint checkpoint = plain.SaveCheckpoint();
  StepFrames(plain, frame, 2);
  const SingleProcess one;
  DistributedSimulation spread(scene, one);
  spread.RestoreCheckpoint(checkpoint);
  EXPECT_EQ(spread.step(), checkpoint.step);
  StepFrames(spread, frame, 2);
  EXPECT_EQ(spread.step(), plain.step());
  EXPECT_EQ(spread.GlobalStateHash(), StateHash(plain.state()));
  // A checkpoint of the predictor-corrector restores too and steps on to its bits.
  Checkpoint corrector = checkpoint;
  corrector.params.time_integration = 1;
  plain.RestoreCheckpoint(corrector);
  spread.RestoreCheckpoint(corrector);
  StepFrames(plain, frame, 2);
  StepFrames(spread, frame, 2);
  EXPECT_EQ(spread.step(), plain.step());
  EXPECT_EQ(spread.GlobalStateHash(), StateHash(plain.state()));
}

TEST(DistributedSimulationTest, OneProcessGivesTheBitsOfSimulation) {
  ExpectSameBits(LoadScene(DYSA_RANKS_SCENE), 3);
}

TEST(DistributedSimulationTest, TheMartinMoyceDamBreakWithShiftingToo) {
  Scene scene = LoadScene("dam_break_martin_moyce");
  scene.params.particle_spacing = 0.0038;  // a coarse column: 15 x 30 x 2 particles
  scene.params.particle_shifting = 2;
  ExpectSameBits(scene, 2);
}

TEST(DistributedSimulationTest, ThePredictorCorrectorToo) {
  Scene scene = LoadScene(DYSA_RANKS_SCENE);
  scene.params.time_integration = 1;
  ExpectSameBits(scene, 3);
}

TEST(DistributedSimulationTest, ThePredictorCorrectorWithShiftingToo) {
  Scene scene = LoadScene("dam_break_martin_moyce");
  scene.params.particle_spacing = 0.0038;
  scene.params.particle_shifting = 2;
  scene.params.time_integration = 1;
  ExpectSameBits(scene, 2);
}

TEST(DistributedSimulationTest, TheSeedModelToo) {
  Scene scene = LoadScene(DYSA_RANKS_SEED_SCENE);
  ExpectSameBits(scene, 8);
}

TEST(DistributedSimulationTest, DfsphToo) {
  // Its solves' stopping tests (fixed-point sums over the owned particles) and the ghost
  // refresh hook (none on one process) leave the bits of Simulation.
  Scene scene = LoadScene(DYSA_RANKS_DFSPH_SCENE);
  ExpectSameBits(scene, 11);  // 22 steps
}

TEST(DistributedSimulationTest, EveryRegisteredSolverRunsAcrossProcesses) {
  // A solver added to the registry must be made to run across processes (its ghost depth, its
  // reductions) or be refused by CheckSupported: this test then says which.
  const Scene scene = LoadScene(DYSA_RANKS_SCENE);
  for (const SolverInfo& info : SolverRegistry()) {
    Scene s = scene;
    s.solver = std::string(info.name);
    EXPECT_NO_THROW(DistributedSimulation::CheckSupported(s, s.params)) << info.name;
  }
}

TEST(DistributedSimulationTest, SolversNotSpreadAreRefusedByName) {
  Scene scene = LoadScene(DYSA_RANKS_SCENE);
  scene.solver = "mps";  // not one of the solvers that run across processes
  try {
    DistributedSimulation::CheckSupported(scene, scene.params);
    FAIL() << "mps accepted";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.field(), "solver");
    EXPECT_THAT(e.message(), HasSubstr("allowed: wcsph, seed, dfsph"));
  }
}

// Half-support cells (grid_cells_per_support 2) run across processes: the slabs count the
// solver grid's half-support layers, the ghosts reach twice as many of them. On one process,
// frame by frame, a plain Simulation's bits (on 1-4 ranks: mpi_ranks_test, ranks_half_cells.json).
TEST(DistributedSimulationTest, HalfSupportCellsGiveTheBitsOfSimulation) {
  Scene scene = LoadScene(DYSA_RANKS_SCENE);
  scene.params.grid_cells_per_support = 2;
  EXPECT_NO_THROW(DistributedSimulation::CheckSupported(scene, scene.params));
  ExpectSameBits(scene, 3);
}

TEST(DistributedSimulationTest, TheDevicePathGivesTheBitsOfSimulation) {
  // The device step (distributed_device_step.cc) with a host stand-in for the GPU
  // (host_device_backend.h): upload, the step, the cells read back, the keys from them; for
  // dfsph its ghost refresh's hook and combined mean errors (one process: nothing to exchange).
  // On 2 and 3 ranks: mpi_device_step_test; on a GPU: distributed_gpu_test.
  for (const char* path : {DYSA_RANKS_SCENE, DYSA_RANKS_SEED_SCENE, DYSA_RANKS_DFSPH_SCENE}) {
    const Scene scene = LoadScene(path);
    const SingleProcess one;
    DistributedSimulation spread(scene, one,
                                 std::make_unique<dysa::testing::HostDeviceBackend>(scene.solver));
    Simulation plain(scene);
    for (int f = 0; f < 6; ++f) {
      const double end = plain.time() + plain.model().FrameTime();
      while (plain.time() < end) plain.Step(end);
      while (spread.time() < end && spread.alarm().empty()) spread.Step(end);
      ASSERT_EQ(spread.step(), plain.step()) << path << ", frame " << f;
      ASSERT_EQ(spread.GlobalStateHash(), StateHash(plain.state())) << path << ", frame " << f;
    }
    EXPECT_EQ(spread.profile().at(1).name, "upload");
  }
}

TEST(DistributedSimulationTest, GpuRanksRunEverySolverTheCpuRanksRun) {
  // Host-side checks, before any device is looked at (distributed_gpu_test steps on one).
  const Device gpu{Device::Kind::kCuda, 0};
  const Scene scene = LoadScene(DYSA_RANKS_SCENE);
  for (const SolverInfo& info : SolverRegistry()) {
    Scene s = scene;
    s.solver = std::string(info.name);  // dfsph too: its ghosts refresh through the device
    EXPECT_NO_THROW(DistributedSimulation::CheckSupported(s, s.params, gpu)) << info.name;
  }
  Params pc = scene.params;
  pc.time_integration = 1;  // the predictor-corrector runs on GPU ranks too
  EXPECT_NO_THROW(DistributedSimulation::CheckSupported(scene, pc, gpu));
  // A solver not made to run across processes is refused on GPU ranks as on CPU ranks.
  Scene unspread = scene;
  unspread.solver = "mps";
  try {
    DistributedSimulation::CheckSupported(unspread, unspread.params, gpu);
    FAIL() << "mps accepted on GPU ranks";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.field(), "solver");
  }
}

TEST(DistributedSimulationTest, AGpuThatCannotRunIsRefusedByFlag) {
  if (DeviceUnavailableReason(Device{Device::Kind::kCuda, 0}).empty()) {
    GTEST_SKIP() << "cuda:0 can run here: distributed_gpu_test steps on it";
  }
  const SingleProcess one;
  try {
    DistributedSimulation sim(LoadScene(DYSA_RANKS_SCENE), one, Device{Device::Kind::kCuda, 0});
    FAIL() << "a GPU that cannot run accepted";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.field(), "device");
  }
}

TEST(DistributedSimulationTest, RanksMapToTheGpusOfTheirHostByLocalRank) {
  // --device cuda without an index: local rank modulo the GPUs.
  EXPECT_EQ(DeviceOfRank("cuda", 0, 2).index, 0);
  EXPECT_EQ(DeviceOfRank("cuda", 1, 2).index, 1);
  EXPECT_EQ(DeviceOfRank("cuda", 2, 2).index, 0);
  EXPECT_EQ(DeviceOfRank("cuda", 3, 1).index, 0);  // 4 ranks sharing one GPU
  EXPECT_TRUE(DeviceOfRank("cuda", 3, 4).is_cuda());
  // No GPU: cuda:0, which the run then refuses saying why.
  EXPECT_EQ(DeviceOfRank("cuda", 3, 0).index, 0);
  // An index is taken as given on every rank; the CPU stays the CPU.
  EXPECT_EQ(DeviceOfRank("cuda:1", 0, 4).index, 1);
  EXPECT_EQ(DeviceOfRank("cuda:1", 3, 4).index, 1);
  EXPECT_FALSE(DeviceOfRank("cpu", 3, 4).is_cuda());
  EXPECT_THROW(DeviceOfRank("gpu", 0, 1), ConfigError);
}

TEST(DistributedSimulationTest, TheLocalRankComesFromTheLauncher) {
  // mpirun sets OMPI_COMM_WORLD_LOCAL_RANK for each rank; other launchers their own variable.
  const char* saved = std::getenv("OMPI_COMM_WORLD_LOCAL_RANK");
  const std::string kept = saved ? saved : "";
  setenv("OMPI_COMM_WORLD_LOCAL_RANK", "3", 1);
  EXPECT_EQ(LocalRank(), 3);
  setenv("OMPI_COMM_WORLD_LOCAL_RANK", "x", 1);  // not a number: the next launcher's, or 0
  const int fallback = LocalRank();
  EXPECT_GE(fallback, 0);
  if (saved) {
    setenv("OMPI_COMM_WORLD_LOCAL_RANK", kept.c_str(), 1);
  } else {
    unsetenv("OMPI_COMM_WORLD_LOCAL_RANK");
  }
}

TEST(DistributedSimulationTest, ExchangeOnOneProcessMovesNothing) {
  const SingleProcess one;
  DistributedSimulation sim(LoadScene(DYSA_RANKS_SCENE), one);
  for (int k = 0; k < 5; ++k) sim.Step();
  EXPECT_EQ(sim.totals().migrated, 0u);
  EXPECT_EQ(sim.totals().ghosts, 0u);
  EXPECT_EQ(sim.particles().size(), sim.TotalParticles());
  EXPECT_EQ(sim.slabs().processes(), 1);
  EXPECT_EQ(sim.axis(), 0);  // x: 40 layers against 20 and 4
}

}  // namespace
}  // namespace dysa::distributed
