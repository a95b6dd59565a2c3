// Tests of server/distributed/src/particle_exchange.cc: the order keys, the key sort and the
// compaction; the exchange itself on MPI ranks is tests/distributed/mpi_ranks_test.sh.
#include "dysa/distributed/particle_exchange.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <stdexcept>
#include <vector>

namespace dysa::distributed {
namespace {

using ::testing::ElementsAre;

TEST(ParticleExchangeTest, OrderKeysAreTheCellAndTheRankWithinIt) {
  NeighborGrid grid;
  grid.Configure(Aabb{Vec3d::Zero(), Vec3d(3, 1, 1)}, 1);  // 3 x 1 x 1 cells
  // Two points in cell 2, one in cell 0, one more in cell 2: sorted 0 | 2 2 2.
  const std::vector<Vec3> points = {Vec3(2.5f, 0.5f, 0.5f), Vec3(0.5f, 0.5f, 0.5f),
                                    Vec3(2.2f, 0.5f, 0.5f), Vec3(2.9f, 0.5f, 0.5f)};
  grid.Sort(points);
  EXPECT_THAT(OrderKeys(grid, points.size()),
              ElementsAre(OrderKey(0, 0), OrderKey(2, 0), OrderKey(2, 1), OrderKey(2, 2)));
}

TEST(ParticleExchangeTest, OrderKeysFromADevicesSortedCellsAreTheGrids) {
  // A GPU's sort reports each sorted particle's cell index (StepBackend::DownloadSortedCells):
  // the keys from those are the grid's.
  NeighborGrid grid;
  grid.Configure(Aabb{Vec3d::Zero(), Vec3d(3, 2, 2)}, 1);  // 3 x 2 x 2 cells
  const std::vector<Vec3> points = {Vec3(2.5f, 1.5f, 0.5f), Vec3(0.5f, 0.5f, 1.5f),
                                    Vec3(2.2f, 1.5f, 0.5f), Vec3(0.1f, 0.5f, 1.5f),
                                    Vec3(1.5f, 0.5f, 0.5f)};
  grid.Sort(points);
  std::vector<uint32_t> cells(points.size());
  for (size_t k = 0; k < points.size(); ++k) {
    cells[k] = grid.CellIndex(grid.SortedCell(uint32_t(k)));
  }
  EXPECT_EQ(OrderKeys(cells), OrderKeys(grid, points.size()));
  EXPECT_THAT(OrderKeys(std::vector<uint32_t>{4, 4, 7, 9, 9, 9}),
              ElementsAre(OrderKey(4, 0), OrderKey(4, 1), OrderKey(7, 0), OrderKey(9, 0),
                          OrderKey(9, 1), OrderKey(9, 2)));
  EXPECT_TRUE(OrderKeys(std::vector<uint32_t>{}).empty());
}

LocalParticles ThreeParticles() {
  LocalParticles p;
  p.particles.Resize(3);
  p.particles.id = {10, 11, 12};
  p.particles.position = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(2, 0, 0)};
  p.particles.density = {100, 101, 102};
  p.key = {OrderKey(5, 1), OrderKey(1, 0), OrderKey(5, 0)};
  p.ghost = {0, 1, 0};
  p.arrays = {{"density", {7, 8, 9}}};
  return p;
}

TEST(ParticleExchangeTest, SortByKeyMovesEveryArrayAlong) {
  LocalParticles p = ThreeParticles();
  SortByKey(p);
  EXPECT_THAT(p.particles.id, ElementsAre(11, 12, 10));
  EXPECT_THAT(p.particles.density, ElementsAre(101, 102, 100));
  EXPECT_EQ(p.particles.position[0], Vec3(1, 0, 0));
  EXPECT_THAT(p.ghost, ElementsAre(1, 0, 0));
  EXPECT_THAT(p.arrays[0].values, ElementsAre(8, 9, 7));
  EXPECT_THAT(p.key, ElementsAre(OrderKey(1, 0), OrderKey(5, 0), OrderKey(5, 1)));
}

TEST(ParticleExchangeTest, TwoParticlesWithOneKeyAreABug) {
  LocalParticles p = ThreeParticles();
  p.key[2] = p.key[0];
  EXPECT_THROW(SortByKey(p), std::logic_error);
}

// What the exchange hands SortByKey: the particles kept, in key order, then the arrivals in any
// order. The result is the full sort's; a key shared across the two runs is still found.
TEST(ParticleExchangeTest, SortByKeyMergesTheKeptRunWithTheArrivals) {
  LocalParticles p;
  const std::vector<uint64_t> keys = {OrderKey(1, 0), OrderKey(3, 0), OrderKey(3, 1),
                                      OrderKey(8, 0),  // kept, in order
                                      OrderKey(9, 0), OrderKey(0, 0), OrderKey(3, 2)};  // arrived
  p.particles.Resize(keys.size());
  p.key = keys;
  for (size_t k = 0; k < keys.size(); ++k) p.particles.id[k] = uint32_t(100 + k);
  p.arrays = {{"density", {0, 1, 2, 3, 4, 5, 6}}};
  SortByKey(p);
  EXPECT_THAT(p.particles.id, ElementsAre(105, 100, 101, 102, 106, 103, 104));
  EXPECT_THAT(p.arrays[0].values, ElementsAre(5, 0, 1, 2, 6, 3, 4));
  EXPECT_TRUE(std::is_sorted(p.key.begin(), p.key.end()));
  // Already in order: nothing moves.
  const std::vector<uint32_t> ids = p.particles.id;
  SortByKey(p);
  EXPECT_EQ(p.particles.id, ids);
  // An arrival with a kept particle's key.
  p.key.push_back(OrderKey(3, 1));
  p.particles.id.push_back(200);
  p.particles.position.emplace_back(0, 0, 0);
  p.particles.velocity.emplace_back(0, 0, 0);
  p.arrays.clear();
  p.particles.density.clear();
  p.particles.pressure.clear();
  EXPECT_THROW(SortByKey(p), std::logic_error);
}

TEST(ParticleExchangeTest, KeepParticlesCompactsThePerParticleArraysOnly) {
  LocalParticles p = ThreeParticles();
  p.arrays.push_back({"other", {1}});  // not one value per particle: left alone
  KeepParticles(std::vector<uint8_t>{1, 0, 1}, p.particles, p.arrays);
  EXPECT_THAT(p.particles.id, ElementsAre(10, 12));
  EXPECT_THAT(p.particles.density, ElementsAre(100, 102));
  EXPECT_THAT(p.arrays[0].values, ElementsAre(7, 9));
  EXPECT_THAT(p.arrays[1].values, ElementsAre(1));
}

TEST(ParticleExchangeTest, OnOneProcessEveryParticleStaysOwned) {
  const SingleProcess one;
  Slabs slabs(4, 1, false, 2);
  LocalParticles p = ThreeParticles();
  p.ghost.clear();
  p.particles.velocity.assign(3, Vec3::Zero());
  ExchangeCounts counts;
  const LocalParticles mine = ExchangeParticles(one, slabs, std::vector<int>{3, 0, 1}, p, counts);
  EXPECT_EQ(counts.migrated, 0u);
  EXPECT_EQ(counts.ghosts, 0u);
  EXPECT_EQ(counts.bytes_sent, 0u);
  EXPECT_THAT(mine.particles.id, ElementsAre(11, 12, 10));  // key order
  EXPECT_THAT(mine.ghost, ElementsAre(0, 0, 0));
  EXPECT_THAT(mine.arrays[0].values, ElementsAre(8, 9, 7));
}

}  // namespace
}  // namespace dysa::distributed
