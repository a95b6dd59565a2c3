// Tests of server/distributed/src/slabs.cc: balanced cuts of whole layers, owners, and the
// ghost layers each process holds (across a periodic seam too).
#include "dysa/distributed/slabs.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

namespace dysa::distributed {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

TEST(SlabsTest, BalanceCutsWhereThePrefixCountReachesEachShare) {
  Slabs slabs(10, 3, false, 2);
  // 60 particles in layers 0-2 (20 each), none elsewhere: a third in each of the first three.
  std::vector<int64_t> counts(10, 0);
  counts[0] = counts[1] = counts[2] = 20;
  slabs.Balance(counts);
  EXPECT_THAT(slabs.cuts(), ElementsAre(0, 1, 2, 10));
  EXPECT_EQ(slabs.OwnerOf(0), 0);
  EXPECT_EQ(slabs.OwnerOf(1), 1);
  EXPECT_EQ(slabs.OwnerOf(9), 2);
}

TEST(SlabsTest, EveryProcessKeepsALayerWhenTheParticlesCrowdOne) {
  Slabs slabs(6, 3, false, 2);
  std::vector<int64_t> counts(6, 0);
  counts[5] = 100;  // all in the last layer
  slabs.Balance(counts);
  EXPECT_THAT(slabs.cuts(), ElementsAre(0, 4, 5, 6));
  counts.assign(6, 0);
  counts[0] = 100;  // all in the first
  slabs.Balance(counts);
  EXPECT_THAT(slabs.cuts(), ElementsAre(0, 1, 2, 6));
}

TEST(SlabsTest, UniformCountsGiveEqualSlabs) {
  Slabs slabs(12, 4, false, 2);
  slabs.Balance(std::vector<int64_t>(12, 7));
  EXPECT_THAT(slabs.cuts(), ElementsAre(0, 3, 6, 9, 12));
}

TEST(SlabsTest, GhostLayersReachDepthLayersIntoTheNeighbours) {
  Slabs slabs(12, 3, false, 2);
  slabs.Balance(std::vector<int64_t>(12, 1));  // [0,4) [4,8) [8,12)
  EXPECT_THAT(slabs.GhostReaders(3), ElementsAre(1));
  EXPECT_THAT(slabs.GhostReaders(2), ElementsAre(1));
  EXPECT_TRUE(slabs.GhostReaders(1).empty());
  EXPECT_THAT(slabs.GhostReaders(4), ElementsAre(0));
  EXPECT_THAT(slabs.GhostReaders(7), ElementsAre(2));
  // Without periodicity the ends see no one across the domain.
  EXPECT_TRUE(slabs.GhostReaders(0).empty());
  EXPECT_TRUE(slabs.GhostReaders(11).empty());
}

TEST(SlabsTest, APeriodicAxisWrapsTheGhostLayers) {
  Slabs slabs(12, 3, true, 2);
  slabs.Balance(std::vector<int64_t>(12, 1));
  EXPECT_THAT(slabs.GhostReaders(0), ElementsAre(2));
  EXPECT_THAT(slabs.GhostReaders(11), ElementsAre(0));
  EXPECT_EQ(slabs.Distance(10, 0), 2);
  EXPECT_EQ(slabs.Distance(9, 0), 3);
}

TEST(SlabsTest, AThinSlabLetsGhostLayersReachPastItsNeighbour) {
  Slabs slabs(8, 4, false, 2);
  std::vector<int64_t> counts(8, 0);
  counts[0] = counts[1] = counts[2] = counts[7] = 10;  // slabs [0,1) [1,2) [2,3) [3,8)
  slabs.Balance(counts);
  ASSERT_THAT(slabs.cuts(), ElementsAre(0, 1, 2, 3, 8));
  // Layer 1 (process 1) is within 2 layers of processes 0, 2 and 3.
  EXPECT_THAT(slabs.GhostReaders(1), ElementsAre(0, 2, 3));
}

TEST(SlabsTest, FewerLayersThanProcessesIsAnErrorNamingTheLimit) {
  try {
    Slabs slabs(3, 4, false, 2);
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("at most 3 ranks"));
  }
}

}  // namespace
}  // namespace dysa::distributed
