// ctest -L mpi, run by mpirun on 2 and 3 ranks: a view stream's reads on the ranks
// (DistributedSimulation::GatherParticlesByIds, PositionBounds, SelectViewSubset; the server's
// Simulation through the ranks' backend) give one process's bits, and each rank sends only its
// share: the asked particles it owns, 60 bytes of bounds, its cells' counts and its part of the
// budget's smallest keys. Every rank runs the plain Simulation too (the test scene is small).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "counting_comm.h"
#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "dysa/distributed/distributed_simulation.h"
#include "dysa/distributed/rank_runner.h"
#include "dysa/distributed/ranks_backend.h"
#include "mpi_test_main.h"
#include "view_reads_testing.h"

#ifndef DYSA_RANKS_SCENE
#error "tests/CMakeLists.txt defines DYSA_RANKS_SCENE"
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

// The same state on the ranks (counting what this rank sends) and on one process.
struct TwoRuns {
  Scene scene = LoadScene(DYSA_RANKS_SCENE);
  CountingComm comm{TestComm()};
  DistributedSimulation spread{scene, comm};
  Simulation plain{scene};
  std::vector<float> position, velocity, density;  // plain's, by id

  TwoRuns() {
    StepFrames(spread, plain.model().FrameTime(), 2);
    StepFrames(plain, plain.model().FrameTime(), 2);
    const size_t n = plain.particle_count();
    position.resize(3 * n);
    velocity.resize(3 * n);
    density.resize(n);
    plain.ReadParticlesById({position, velocity, density});
    comm.Clear();
  }
  // How many of `ids` this rank owns.
  size_t Owned(const std::vector<uint32_t>& ids) const {
    std::vector<uint32_t> sorted = ids;
    std::sort(sorted.begin(), sorted.end());
    size_t owned = 0;
    for (const uint32_t id : spread.particles().id) {
      owned += std::binary_search(sorted.begin(), sorted.end(), id) ? 1 : 0;
    }
    return owned;
  }
  void ExpectPlainValues(const ParticleArrays& got, size_t k, uint32_t id) const {
    for (int a = 0; a < 3; ++a) {
      ASSERT_EQ(got.position[k][a], position[3 * id + a]) << "id " << id;
      if (!got.velocity.empty()) {
        ASSERT_EQ(got.velocity[k][a], velocity[3 * id + a]) << "id " << id;
      }
    }
    ASSERT_EQ(got.density[k], density[id]) << "id " << id;
  }
};

int64_t SumOverRanks(size_t value) {
  std::vector<int64_t> v{int64_t(value)};
  TestComm().SumInPlace(v);
  return v[0];
}

TEST(MpiViewReadsTest, AReadByIdsTakesOnlyTheAskedParticlesFromEachRank) {
  TwoRuns runs;
  const size_t n = runs.plain.particle_count();
  std::vector<uint32_t> ids;  // every 7th, decreasing
  for (int64_t k = int64_t(n) - 1; k >= 0; k -= 7) ids.push_back(uint32_t(k));
  const ParticleArrays got =
      runs.spread.GatherParticlesByIds(ids, kReadPosition | kReadVelocity | kReadDensity);
  // Each rank sent its asked particles (id, position, velocity, density: 32 bytes), no other.
  const size_t owned = runs.Owned(ids);
  EXPECT_GT(owned, 0u);
  EXPECT_LT(owned, ids.size());
  EXPECT_EQ(runs.comm.gathered, std::vector<size_t>{owned * 32});
  EXPECT_EQ(SumOverRanks(owned), int64_t(ids.size()));
  if (TestComm().rank() != 0) {
    EXPECT_EQ(got.size(), 0u);
    return;
  }
  ASSERT_EQ(got.id, ids);  // in the asked order
  for (size_t k = 0; k < ids.size(); ++k) runs.ExpectPlainValues(got, k, ids[k]);
}

TEST(MpiViewReadsTest, PositionBoundsMoveSixtyBytesPerRank) {
  TwoRuns runs;
  const Simulation::PositionBounds got = runs.spread.PositionBounds();
  EXPECT_EQ(runs.comm.gathered, std::vector<size_t>{60});  // per axis 2 extremes, a zero's key
  EXPECT_EQ(runs.comm.max_values, 0u);
  EXPECT_EQ(runs.comm.all_to_all_bytes, 0u);
  if (TestComm().rank() != 0) return;
  const Simulation::PositionBounds want = runs.plain.ReadPositionBounds();
  EXPECT_EQ(got.lo, want.lo);
  EXPECT_EQ(got.hi, want.hi);
}

TEST(MpiViewReadsTest, AZeroExtremeTakesTheSignOfTheFirstZeroInStorageOrder) {
  // One process signs a zero extreme as its first zero in storage order (a sequential scan's):
  // on the ranks the first in order key, wherever it lives. A checkpoint's order is the storage
  // order after its restore, on one process and on the ranks (the order key).
  const Scene scene = LoadScene(DYSA_RANKS_SCENE);
  Simulation plain(scene);
  plain.StepFrame();  // the storage in cell order (x fastest), not the spawn's
  Checkpoint c = plain.SaveCheckpoint();
  // Two particles get y = 0, one +0 and one -0 (every other y stays above): the first in
  // storage order far right (the last rank's slab along x), the second far left (rank 0's), so
  // that the ranks' order is not the storage order.
  const size_t n = c.id.size();
  size_t first = 0, second = n - 1;
  for (size_t i = 0; i < n; ++i) {
    c.position[i][1] = std::max(c.position[i][1], Real(0.001));
    if (i < n / 2 && c.position[i][0] > c.position[first][0]) first = i;
    if (i >= n / 2 && c.position[i][0] < c.position[second][0]) second = i;
  }
  for (const float first_sign : {-1.0f, 1.0f}) {
    c.position[first][1] = std::copysign(0.0f, first_sign);
    c.position[second][1] = std::copysign(0.0f, -first_sign);
    plain.RestoreCheckpoint(c);
    DistributedSimulation spread(scene, TestComm());
    spread.RestoreCheckpoint(c);
    EXPECT_EQ(spread.particles().size() < c.id.size(), TestComm().size() > 1);
    const Simulation::PositionBounds got = spread.PositionBounds();
    if (TestComm().rank() != 0) continue;
    const std::vector<uint32_t>& mine = spread.particles().id;
    EXPECT_EQ(std::count(mine.begin(), mine.end(), c.id[first]), 0);  // another rank's
    EXPECT_EQ(std::count(mine.begin(), mine.end(), c.id[second]), 1);
    const Simulation::PositionBounds want = plain.ReadPositionBounds();
    EXPECT_EQ(want.lo[1], 0.0f);
    EXPECT_EQ(std::signbit(want.lo[1]), first_sign < 0);
    EXPECT_EQ(std::signbit(got.lo[1]), std::signbit(want.lo[1])) << "first sign " << first_sign;
    EXPECT_EQ(got.lo, want.lo);
    EXPECT_EQ(got.hi, want.hi);
  }
}

TEST(MpiViewReadsTest, AViewSubsetIsOneProcesssAndEachRankSendsItsShare) {
  TwoRuns runs;
  const size_t n = runs.plain.particle_count();
  for (const auto& box : TestViewBoxes()) {
    for (const uint32_t stride : {1u, 3u}) {
      for (const uint64_t budget : {uint64_t(0), uint64_t(37), uint64_t(n / 5), uint64_t(n)}) {
        SCOPED_TRACE("stride " + std::to_string(stride) + ", budget " + std::to_string(budget));
        auto plain_calls = std::make_shared<int>(0), calls = std::make_shared<int>(0);
        std::vector<uint32_t> want;
        std::vector<float> unused(3 * n), unused_density(n);
        runs.plain.ReadViewSubset(TestViewRequest(box[0], box[1], stride, plain_calls), budget,
                                  want, {unused, {}, unused_density});
        runs.comm.Clear();
        const GatheredViewSubset got = runs.spread.SelectViewSubset(
            TestViewRequest(box[0], box[1], stride, calls), budget, kReadPosition | kReadDensity);
        EXPECT_EQ(*calls, TestComm().rank() == 0 ? 1 : 0);  // process 0 weighs
        // The chosen particles this rank owns (id, position, density: 20 bytes), last; before
        // them its cells' counts and, unless every candidate goes, its (key, id) pairs.
        size_t candidates = 0;
        for (const uint32_t id : runs.spread.particles().id) candidates += id % stride == 0;
        const bool every = budget >= (n + stride - 1) / stride;
        ASSERT_EQ(runs.comm.gathered.size(), every ? 2u : 3u);
        EXPECT_LE(runs.comm.gathered[0], 8 * candidates);
        if (!every) {
          EXPECT_EQ(runs.comm.gathered[1], 8 * std::min<uint64_t>(budget, candidates));
        }
        EXPECT_EQ(runs.comm.gathered.back(), runs.Owned(want) * 20);
        if (TestComm().rank() != 0) continue;
        ASSERT_EQ(got.ids, want);
        for (size_t k = 0; k < want.size(); ++k) runs.ExpectPlainValues(got.particles, k, want[k]);
      }
    }
  }
}

// The server's simulation on the ranks: process 0's Simulation on the ranks' backend, the
// other ranks serving its commands, reads what one process reads.
TEST(MpiViewReadsTest, TheServersViewReadsOnRanksAreOneProcesss) {
  auto runner = std::make_shared<RankRunner>(TestComm());
  if (TestComm().rank() != 0) {
    ServeRanks(*runner);
    return;
  }
  struct StopRanks {  // however the test ends, the other ranks stop serving
    std::shared_ptr<RankRunner> runner;
    ~StopRanks() { runner->Send(StopCommand()); }
  } stop{runner};
  const Scene scene = LoadScene(DYSA_RANKS_SCENE);
  Simulation spread(scene, Device{}, RanksBackendFactory(runner));
  Simulation plain(scene);
  for (int f = 0; f < 2; ++f) {
    spread.StepFrame();
    plain.StepFrame();
  }
  ExpectSameViewReads(spread, plain);
}

}  // namespace
}  // namespace dysa::distributed
