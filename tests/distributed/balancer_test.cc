// Tests of server/distributed/src/balancer.cc: the cuts from given per-layer work and process
// speeds, and the balancer's decisions on one process and, with the other processes modelled, on
// process 0 of three.
#include "dysa/distributed/balancer.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <stdexcept>
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

// Process 0 of three whose collectives see the other two as `model` says: SumInPlace adds their
// parts of the balancer's sum (the only collective Rebalance calls).
class ModelledPeers final : public Communicator {
 public:
  explicit ModelledPeers(std::function<void(std::span<int64_t>)> model)
      : model_(std::move(model)) {}
  int rank() const override { return 0; }
  int size() const override { return 3; }
  void MaxInPlace(std::span<double>) const override { Unused(); }
  void SumInPlace(std::span<int64_t> values) const override { model_(values); }
  std::vector<Bytes> AllToAll(const std::vector<Bytes>&) const override { Unused(); }
  std::vector<Bytes> GatherToRoot(std::span<const std::byte>) const override { Unused(); }
  void Broadcast(Bytes&) const override { Unused(); }

 private:
  [[noreturn]] static void Unused() { throw std::logic_error("not a collective of the balancer"); }
  std::function<void(std::span<int64_t>)> model_;
};

// Steps `windows` windows of three processes on the slabs' layers, of equal work, process p taking
// step_ms(p, its work) a step, and returns the balancer of process 0 (the cuts in `slabs`).
Balancer RunWindows(Slabs& slabs, int windows, const std::function<double(int, int64_t)>& step_ms,
                    const BalanceSettings& settings = {}, std::vector<int64_t> weights = {}) {
  const int layers = slabs.layers();
  if (weights.empty()) weights.assign(size_t(layers), 10);
  const auto work_of = [&](int p) {
    int64_t w = 0;
    for (int l = slabs.begin(p); l < slabs.begin(p + 1); ++l) w += weights[size_t(l)];
    return w;
  };
  Balancer balancer(settings);
  const int window = balancer.settings().window;
  const ModelledPeers peers([&](std::span<int64_t> sums) {
    for (int p = 1; p < 3; ++p) {
      for (int l = slabs.begin(p); l < slabs.begin(p + 1); ++l) {
        sums[size_t(l)] += window * weights[size_t(l)];
      }
      // What each process puts in its time's place: its work when balancing by work.
      sums[size_t(layers + p)] += settings.by_work
                                      ? window * work_of(p)
                                      : std::llround(window * step_ms(p, work_of(p)) * 1e6);
      sums[size_t(layers + 3 + p)] += window * work_of(p);
    }
  });
  for (int step = 0; step < windows * window; ++step) {
    balancer.Record(step_ms(0, work_of(0)), slabs, 0, weights);
    balancer.Rebalance(peers, slabs);
  }
  return balancer;
}

TEST(BalancerTest, AReCutThatBalancesStays) {
  // Process 0 takes three times as long per unit of work: one re-cut gives it 2 of the 12
  // layers (costs 60, 60 and 40 against 120, 40 and 40: max/mean 1.125 from 1.8), and it stays.
  Slabs slabs(12, 3, false, 2);
  const Balancer balancer = RunWindows(
      slabs, 8, [](int p, int64_t work) { return (p == 0 ? 3e-3 : 1e-3) * double(work); });
  EXPECT_EQ(balancer.report().recuts, 1u);
  EXPECT_EQ(balancer.report().undone, 0u);
  EXPECT_THAT(std::vector<int>(slabs.cuts().begin(), slabs.cuts().end()), ElementsAre(0, 2, 8, 12));
  EXPECT_NEAR(balancer.report().first_ratio, 1.8, 1e-6);
  EXPECT_NEAR(balancer.report().last_ratio, 1.125, 1e-6);
}

TEST(BalancerTest, StepTimesThatDoNotFollowTheWorkEmptyNoProcess) {
  // Process 0 takes 1.3 ms a step and the others 1 ms whatever their work (a fixed cost per
  // step; processes sharing one GPU): moving work away from it lowers nothing. Each re-cut is
  // undone at the next window, re-cutting pauses for 1, 2, 4, ... windows, and process 0 keeps
  // its third of the layers instead of being emptied step by step. (30 layers: a re-cut that
  // promises more than the 5% margin exists.)
  Slabs slabs(30, 3, false, 2);
  const Balancer balancer =
      RunWindows(slabs, 40, [](int p, int64_t) { return p == 0 ? 1.3 : 1.0; });
  // 40 windows: re-cuts at windows 1, 4, 8, 14 and 24 (after pauses of 1, 2, 4 and 8
  // windows; the fifth pause, 16 windows, outlasts the run), each undone at the next window.
  EXPECT_EQ(balancer.report().recuts, 5u);
  EXPECT_EQ(balancer.report().undone, 5u);
  EXPECT_THAT(std::vector<int>(slabs.cuts().begin(), slabs.cuts().end()),
              ElementsAre(0, 10, 20, 30));
}

TEST(BalancerTest, ATimeFarOffTheOthersStillLeavesTheProcessWork) {
  // The first 6 of 30 layers are empty, and process 0's steps take 50 times the others' per
  // unit of work (a loaded machine, not the process). Its estimated speed is held within
  // 4 times the fastest (kMostSlower), so it keeps fluid: unbounded, it would be given only the
  // empty layers.
  std::vector<int64_t> weights(30, 10);
  std::fill(weights.begin(), weights.begin() + 6, 0);
  Slabs slabs(30, 3, false, 2);
  const Balancer balancer = RunWindows(
      slabs, 20, [](int p, int64_t work) { return (p == 0 ? 5e-2 : 1e-3) * double(work); }, {},
      weights);
  EXPECT_GE(balancer.report().recuts, 1u);
  int64_t work0 = 0;
  for (int l = slabs.begin(0); l < slabs.begin(1); ++l) work0 += weights[size_t(l)];
  EXPECT_GT(work0, 0);
}

TEST(BalancerTest, ByWorkTheStepTimesAreNotRead) {
  // GPU ranks: process 0 takes 1.3 ms a step whatever its work, as in the test above, but by
  // work equal slabs are balanced: no re-cut, max/mean 1.
  BalanceSettings by_work;
  by_work.by_work = true;
  Slabs slabs(30, 3, false, 2);
  Balancer balancer = RunWindows(
      slabs, 40, [](int p, int64_t) { return p == 0 ? 1.3 : 1.0; }, by_work);
  EXPECT_EQ(balancer.report().recuts, 0u);
  EXPECT_TRUE(balancer.report().by_work);
  EXPECT_DOUBLE_EQ(balancer.report().first_ratio, 1.0);
  // Uneven slabs (work 50, 50 and 200) are re-cut to equal work once, however slow process 0
  // looks (10 times slower per unit of work), and the re-cut stays.
  slabs.SetCuts(std::vector<int>{0, 5, 10, 30});
  balancer = RunWindows(
      slabs, 10, [](int p, int64_t work) { return (p == 0 ? 1e-2 : 1e-3) * double(work); },
      by_work);
  EXPECT_EQ(balancer.report().recuts, 1u);
  EXPECT_EQ(balancer.report().undone, 0u);
  EXPECT_NEAR(balancer.report().first_ratio, 2.0, 1e-12);
  EXPECT_DOUBLE_EQ(balancer.report().last_ratio, 1.0);
  EXPECT_THAT(std::vector<int>(slabs.cuts().begin(), slabs.cuts().end()),
              ElementsAre(0, 10, 20, 30));
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
