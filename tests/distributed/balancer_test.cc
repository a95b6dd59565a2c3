// Tests of server/distributed/src/balancer.cc: the cuts from given per-layer work and process
// speeds, and the balancer's decisions on one process.
#include "dysa/distributed/balancer.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <vector>

namespace dysa::distributed {
namespace {

using ::testing::ElementsAre;

TEST(BalancerTest, EqualSpeedsBalanceTheWork) {
  // 12 layers of equal work on 4 equal processes: 3 layers each.
  const std::vector<int64_t> work(12, 5);
  const std::vector<double> speed(4, 1.0);
  const std::vector<int> cuts = CutsForCosts(work, speed);
  EXPECT_THAT(cuts, ElementsAre(0, 3, 6, 9, 12));
  EXPECT_DOUBLE_EQ(CostRatio(work, speed, cuts), 1.0);
}

TEST(BalancerTest, ASlowProcessGetsLessWork) {
  // Process 0 takes three times as long per unit of work: a quarter of 8 equal layers.
  const std::vector<int64_t> work(8, 10);
  const std::vector<double> speed = {3.0, 1.0};
  const std::vector<int> cuts = CutsForCosts(work, speed);
  EXPECT_THAT(cuts, ElementsAre(0, 2, 8));
  EXPECT_DOUBLE_EQ(CostRatio(work, speed, cuts), 1.0);
  // The equal cut it replaces: costs 120 and 40, max/mean 1.5.
  EXPECT_DOUBLE_EQ(CostRatio(work, speed, std::vector<int>{0, 4, 8}), 1.5);
}

TEST(BalancerTest, UnevenWorkMovesTheCutsToIt) {
  // All the work in layers 6-9 of 10 (boundary and fluid): two equal processes split it there.
  std::vector<int64_t> work(10, 0);
  work[6] = work[7] = work[8] = work[9] = 7;
  const std::vector<int> cuts = CutsForCosts(work, std::vector<double>{1.0, 1.0});
  EXPECT_THAT(cuts, ElementsAre(0, 8, 10));
}

TEST(BalancerTest, EveryProcessKeepsALayer) {
  std::vector<int64_t> work(6, 0);
  work[0] = 100;  // all in the first layer: the first process takes the empty layers it can
  EXPECT_THAT(CutsForCosts(work, std::vector<double>(3, 1.0)), ElementsAre(0, 4, 5, 6));
  work.assign(6, 0);
  work[5] = 100;  // all in the last
  const std::vector<int> cuts = CutsForCosts(work, std::vector<double>(3, 1.0));
  EXPECT_EQ(cuts.front(), 0);
  EXPECT_EQ(cuts.back(), 6);
  EXPECT_EQ(cuts[2], 5);
  // No work at all: equal layer counts.
  EXPECT_THAT(CutsForCosts(std::vector<int64_t>(6, 0), std::vector<double>(3, 1.0)),
              ElementsAre(0, 2, 4, 6));
}

TEST(BalancerTest, TheSameInputsGiveTheSameCuts) {
  std::vector<int64_t> work;
  for (int l = 0; l < 40; ++l) work.push_back((l * 37) % 11 + (l > 20 ? 30 : 0));
  const std::vector<double> speed = {1.3, 0.7, 2.1, 1.0};
  const std::vector<int> cuts = CutsForCosts(work, speed);
  EXPECT_EQ(CutsForCosts(work, speed), cuts);
  EXPECT_LT(CostRatio(work, speed, cuts),
            CostRatio(work, speed, std::vector<int>{0, 10, 20, 30, 40}));
}

TEST(BalancerTest, OneProcessNeverReCuts) {
  SingleProcess one;
  Slabs slabs(10, 1, false, 2);
  Balancer balancer;
  const std::vector<int64_t> weights(10, 3);
  for (int step = 0; step < 20; ++step) {
    balancer.Record(1.0 + step, slabs, 0, weights);
    EXPECT_FALSE(balancer.Rebalance(one, slabs));
  }
  EXPECT_EQ(balancer.report().windows, uint64_t(20 / balancer.settings().window));
  EXPECT_DOUBLE_EQ(balancer.report().first_ratio, 1.0);
  EXPECT_EQ(balancer.report().recuts, 0u);
}

TEST(BalancerTest, SetCutsChecksTheCuts) {
  Slabs slabs(10, 2, false, 2);
  slabs.SetCuts(std::vector<int>{0, 3, 10});
  EXPECT_EQ(slabs.OwnerOf(2), 0);
  EXPECT_EQ(slabs.OwnerOf(3), 1);
  EXPECT_THROW(slabs.SetCuts(std::vector<int>{0, 0, 10}), std::invalid_argument);
  EXPECT_THROW(slabs.SetCuts(std::vector<int>{0, 5, 9}), std::invalid_argument);
}

}  // namespace
}  // namespace dysa::distributed
