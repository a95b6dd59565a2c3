// ctest -L mpi, run by mpirun on 2 and 3 ranks: a checkpoint taken on the ranks is the one a
// single process's Simulation takes of the same state, bit for bit, and a single process's
// checkpoint restores on the ranks and steps on to the bits of the single process. Together: a
// checkpoint taken on N ranks restores on M. Every rank runs the plain Simulation too (the test
// scene is small); rank 0 compares. For wcsph (ranks_dam_break.json: its carried density) and
// dfsph (ranks_dfsph.json: its warm start, which the next steps read).
#include <gtest/gtest.h>

#include <algorithm>

#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "dysa/detail_rank.h"
#include "dysa/distributed/distributed_simulation.h"
#include "mpi_test_main.h"

#if !defined(DYSA_RANKS_SCENE) || !defined(DYSA_RANKS_DFSPH_SCENE)
#error "tests/CMakeLists.txt defines DYSA_RANKS_SCENE and DYSA_RANKS_DFSPH_SCENE"
#endif

namespace dysa::distributed {
namespace {

template <class Sim>
void StepFrames(Sim& sim, double frame_time, int frames) {
  for (int f = 0; f < frames; ++f) {
    const double end = sim.time() + frame_time;
    while (sim.time() < end) sim.Step(end);
  }
}

void ExpectACheckpointOnRanksIsTheOneOfOneProcess(const char* path) {
  const Scene scene = LoadScene(path);
  DistributedSimulation spread(scene, TestComm());
  Simulation plain(scene);
  const double frame = plain.model().FrameTime();
  StepFrames(spread, frame, 3);
  StepFrames(plain, frame, 3);
  const Checkpoint b = spread.SaveCheckpoint();
  EXPECT_GT(spread.totals().migrated + spread.totals().ghosts, 0u);
  if (TestComm().rank() != 0) return;
  const Checkpoint a = plain.SaveCheckpoint();
  EXPECT_EQ(b.step, a.step);
  EXPECT_EQ(b.time, a.time);
  EXPECT_EQ(b.id, a.id);
  EXPECT_TRUE(b.position == a.position);
  EXPECT_TRUE(b.velocity == a.velocity);
  ASSERT_EQ(b.solver_arrays.size(), a.solver_arrays.size());
  for (size_t k = 0; k < a.solver_arrays.size(); ++k) {
    EXPECT_EQ(b.solver_arrays[k].values, a.solver_arrays[k].values) << a.solver_arrays[k].name;
  }
}

void ExpectAOneProcessCheckpointRestoresOnRanks(const char* path) {
  const Scene scene = LoadScene(path);
  Simulation plain(scene);
  const double frame = plain.model().FrameTime();
  StepFrames(plain, frame, 2);
  const Checkpoint checkpoint = plain.SaveCheckpoint();
  StepFrames(plain, frame, 2);
  DistributedSimulation spread(scene, TestComm());
  spread.RestoreCheckpoint(checkpoint);
  StepFrames(spread, frame, 2);
  const uint64_t hash = spread.GlobalStateHash();
  if (TestComm().rank() != 0) return;
  EXPECT_EQ(spread.step(), plain.step());
  EXPECT_EQ(hash, StateHash(plain.state()));
}

TEST(MpiCheckpointTest, EachRankSpawnsOnlyItsSlab) {
  // The ranks walk the scene's spawn without storing it (VisitSpawnedParticles): each holds its
  // slab's particles, in arrays no larger than that, and together they hold the scene's, in the
  // order one process spawns them (ids increasing on each rank).
  const Scene scene = LoadScene(DYSA_RANKS_SCENE);
  const DistributedSimulation spread(scene, TestComm());
  const ParticleArrays& mine = spread.particles();
  const uint64_t total = spread.TotalParticles();
  EXPECT_LT(mine.size(), total);
  EXPECT_GT(mine.size(), 0u);
  EXPECT_EQ(mine.id.capacity(), mine.size());
  EXPECT_EQ(mine.position.capacity(), mine.size());
  EXPECT_TRUE(std::is_sorted(mine.id.begin(), mine.id.end()));
  ParticleArrays all;
  SpawnParticles(scene, scene.params, all);
  EXPECT_EQ(total, all.size());
  for (size_t k = 0; k < mine.size(); ++k) {
    ASSERT_EQ(mine.position[k], all.position[mine.id[k]]) << "id " << mine.id[k];
    ASSERT_EQ(mine.velocity[k], all.velocity[mine.id[k]]) << "id " << mine.id[k];
  }
}

TEST(MpiCheckpointTest, ASubsetGatherTakesOnlyTheSubsetFromEachRank) {
  // A budgeted frame on ranks: each rank sends its particles of BelowRank(id, T) only, and
  // process 0 gets exactly one process's subset, in one process's storage order.
  const Scene scene = LoadScene(DYSA_RANKS_SCENE);
  DistributedSimulation spread(scene, TestComm());
  Simulation plain(scene);
  const double frame = plain.model().FrameTime();
  StepFrames(spread, frame, 2);
  StepFrames(plain, frame, 2);
  constexpr uint32_t kThreshold = 1u << 30;  // a quarter of the ranks
  const ParticleArrays subset = spread.GatherParticlesBelowRank(kThreshold);
  if (TestComm().rank() != 0) {
    EXPECT_EQ(subset.size(), 0u);
    return;
  }
  const ParticleArrays& all = plain.state().particles;
  std::vector<size_t> kept;
  for (size_t i = 0; i < all.size(); ++i) {
    if (BelowRank(all.id[i], kThreshold)) kept.push_back(i);
  }
  ASSERT_EQ(subset.size(), kept.size());
  EXPECT_LT(subset.size(), all.size() / 2);
  for (size_t k = 0; k < kept.size(); ++k) {
    ASSERT_EQ(subset.id[k], all.id[kept[k]]);
    ASSERT_EQ(subset.position[k], all.position[kept[k]]);
    ASSERT_EQ(subset.velocity[k], all.velocity[kept[k]]);
    ASSERT_EQ(subset.density[k], all.density[kept[k]]);
  }
}

TEST(MpiCheckpointTest, ACheckpointOnRanksIsTheOneOfOneProcess) {
  ExpectACheckpointOnRanksIsTheOneOfOneProcess(DYSA_RANKS_SCENE);
}

TEST(MpiCheckpointTest, AOneProcessCheckpointRestoresOnRanks) {
  ExpectAOneProcessCheckpointRestoresOnRanks(DYSA_RANKS_SCENE);
}

TEST(MpiCheckpointTest, DfsphsCheckpointOnRanksIsTheOneOfOneProcess) {
  ExpectACheckpointOnRanksIsTheOneOfOneProcess(DYSA_RANKS_DFSPH_SCENE);
}

TEST(MpiCheckpointTest, DfsphsOneProcessCheckpointRestoresOnRanks) {
  ExpectAOneProcessCheckpointRestoresOnRanks(DYSA_RANKS_DFSPH_SCENE);
}

}  // namespace
}  // namespace dysa::distributed
