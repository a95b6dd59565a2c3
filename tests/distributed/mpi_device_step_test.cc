// ctest -L mpi, run by mpirun on 2 and 3 ranks: the ranks' device step
// (distributed_device_step.cc: the host's exchange, the upload in key order, a device's step
// with the owned layers' maxima combined over the ranks, the download, the owners and order keys
// from the device's sorted cells, the predictor-corrector's half-step check, the ghosts dropped)
// gives the bits of one process's Simulation, with particles migrating, where there is no GPU:
// a host stand-in (host_device_backend.h) takes the device's place. For dfsph also its hook
// (ProcessShare::device_ghosts): the refresh planned from the device's sort, the ghosts'
// velocities exchanged through it after every update inside the step, and the solves' mean
// errors over the owned particles summed over the ranks. Every rank runs the plain
// Simulation too; rank 0 compares. On a GPU: distributed_gpu_test, mpi_gpu_ranks_test.
#include <gtest/gtest.h>

#include <cstdint>
#include <memory>

#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "dysa/distributed/distributed_simulation.h"
#include "host_device_backend.h"
#include "mpi_test_main.h"

#if !defined(DYSA_RANKS_SCENE) || !defined(DYSA_RANKS_PERIODIC_SCENE) || \
    !defined(DYSA_RANKS_PC_SCENE) || !defined(DYSA_RANKS_SEED_SCENE) ||  \
    !defined(DYSA_RANKS_DFSPH_SCENE)
#error "tests/CMakeLists.txt defines DYSA_RANKS_SCENE and the other DYSA_RANKS_*_SCENE paths"
#endif

namespace dysa::distributed {
namespace {

// Frame by frame (each step capped at the frame's end, as `dysa run`), the state hash of the
// device path on the ranks against one process's.
void ExpectTheBitsOfOneProcess(const char* path, int frames) {
  const Scene scene = LoadScene(path);
  DistributedSimulation spread(scene, TestComm(),
                               std::make_unique<dysa::testing::HostDeviceBackend>(scene.solver));
  Simulation plain(scene);
  for (int f = 0; f < frames; ++f) {
    const double end = plain.time() + plain.model().FrameTime();
    while (plain.time() < end) plain.Step(end);
    while (spread.time() < end && spread.alarm().empty()) spread.Step(end);
    EXPECT_EQ(spread.alarm(), "");
    EXPECT_EQ(spread.step(), plain.step()) << "frame " << f;
    const uint64_t hash = spread.GlobalStateHash();
    if (TestComm().rank() == 0) {
      EXPECT_EQ(hash, StateHash(plain.state())) << "frame " << f;
    }
    // Every rank stops at the first frame that failed on one (rank 0 compares the hashes), so
    // that none waits for the others in the next frame's collectives.
    int64_t failed = ::testing::Test::HasFailure() ? 1 : 0;
    TestComm().SumInPlace({&failed, 1});
    if (failed > 0) return;
  }
  EXPECT_GT(spread.step(), 20u);
  EXPECT_EQ(spread.profile().at(1).name, "upload");
  // Particles crossed between ranks and were held as ghosts.
  int64_t moved[2] = {int64_t(spread.totals().migrated), int64_t(spread.totals().ghosts)};
  TestComm().SumInPlace(moved);
  EXPECT_GT(moved[0], 0);
  EXPECT_GT(moved[1], 0);
  EXPECT_EQ(spread.TotalParticles(), plain.particle_count());
}

TEST(MpiDeviceStepTest, WcsphGivesTheBitsOfOneProcess) {
  ExpectTheBitsOfOneProcess(DYSA_RANKS_SCENE, 12);
}

TEST(MpiDeviceStepTest, AcrossThePeriodicSeamWithShifting) {
  ExpectTheBitsOfOneProcess(DYSA_RANKS_PERIODIC_SCENE, 12);
}

TEST(MpiDeviceStepTest, ThePredictorCorrector) {
  ExpectTheBitsOfOneProcess(DYSA_RANKS_PC_SCENE, 12);
}

TEST(MpiDeviceStepTest, TheSeed) { ExpectTheBitsOfOneProcess(DYSA_RANKS_SEED_SCENE, 10); }

// dfsph's ghosts take their owners' velocities after every update inside the step, through the
// device's hook; without the refresh, or with a mean error over the ghosts too, the hashes on 2
// and 3 ranks differ from one process's (docs/distributed.md).
TEST(MpiDeviceStepTest, DfsphRefreshesItsGhostsThroughTheDevicesHook) {
  ExpectTheBitsOfOneProcess(DYSA_RANKS_DFSPH_SCENE, 40);
}

}  // namespace
}  // namespace dysa::distributed
