// ctest -L mpi, run by mpirun on 2 and 3 ranks: the ranks' device step
// (distributed_device_step.cc: the host's exchange, the upload in key order, a device's step
// with the owned layers' maxima combined over the ranks, the download, the owners and order keys
// from the device's sorted cells, the predictor-corrector's half-step check, the ghosts dropped)
// gives the bits of one process's Simulation, with particles migrating, where there is no GPU:
// a host stand-in (host_device_backend.h) takes the device's place. Every rank runs the plain
// Simulation too; rank 0 compares. On a GPU: distributed_gpu_test, mpi_gpu_ranks_test.
#include <gtest/gtest.h>

#include <memory>

#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "dysa/distributed/distributed_simulation.h"
#include "host_device_backend.h"
#include "mpi_test_main.h"

#if !defined(DYSA_RANKS_SCENE) || !defined(DYSA_RANKS_PERIODIC_SCENE) || \
    !defined(DYSA_RANKS_PC_SCENE) || !defined(DYSA_RANKS_SEED_SCENE)
#error "tests/CMakeLists.txt defines DYSA_RANKS_SCENE, _PERIODIC_SCENE, _PC_SCENE, _SEED_SCENE"
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
    ASSERT_EQ(spread.alarm(), "");
    ASSERT_EQ(spread.step(), plain.step()) << "frame " << f;
    const uint64_t hash = spread.GlobalStateHash();
    if (TestComm().rank() == 0) {
      ASSERT_EQ(hash, StateHash(plain.state())) << "frame " << f;
    }
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

}  // namespace
}  // namespace dysa::distributed
