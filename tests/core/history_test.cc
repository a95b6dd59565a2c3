// Tests of dysa/core/history.h: stepping back reaches bit-identical states, stepping forward
// again repeats the first pass exactly, parameter changes are part of the history, and memory
// stays within the budget.
#include "dysa/core/history.h"

#include <gtest/gtest.h>

#include <vector>

#include "dysa/core/scene.h"

namespace dysa {
namespace {

// 10^3 particles 0.133 m apart with h = 0.2 m: every pass shapes the state from the first step.
Scene SmallDenseScene() {
  Scene scene = LoadScene("seed_basic");
  SetParam(scene.params, "particle_quantity", 10);
  SetParam(scene.params, "spawn_size", 1.2);
  return scene;
}

// Hashes of frames 0..n of a fresh run, recording every frame into `history`.
std::vector<uint64_t> RunAndHash(Simulation& sim, History& history, int frames) {
  std::vector<uint64_t> hashes{StateHash(sim.state())};
  for (int f = 0; f < frames; ++f) {
    sim.StepFrame();
    history.Record(sim);
    hashes.push_back(StateHash(sim.state()));
  }
  return hashes;
}

TEST(HistoryTest, CheckpointRestoreRepeatsTheFollowingStepsBitForBit) {
  Simulation sim(SmallDenseScene());
  for (int f = 0; f < 5; ++f) sim.StepFrame();
  const Checkpoint checkpoint = sim.SaveCheckpoint();
  for (int f = 0; f < 5; ++f) sim.StepFrame();
  const uint64_t first = StateHash(sim.state());
  const uint64_t first_step = sim.state().step;

  sim.RestoreCheckpoint(checkpoint);
  EXPECT_EQ(sim.state().frame, 5u);
  for (int f = 0; f < 5; ++f) sim.StepFrame();
  EXPECT_EQ(StateHash(sim.state()), first);
  EXPECT_EQ(sim.state().step, first_step);
}

TEST(HistoryTest, StepBackThenForwardGivesTheFirstPassBitForBit) {
  Simulation sim(SmallDenseScene());
  History history(HistoryConfig{.frames = 40, .max_bytes = size_t{64} << 20, .max_interval = 4});
  history.Start(sim);
  const std::vector<uint64_t> first = RunAndHash(sim, history, 30);
  ASSERT_NE(first[7], first[30]);

  // Frame 7 is not a checkpoint frame with interval 4: it is re-simulated from frame 4.
  EXPECT_EQ(history.Restore(sim, 7), 7u);
  EXPECT_EQ(sim.state().frame, 7u);
  EXPECT_EQ(StateHash(sim.state()), first[7]);
  for (int f = 8; f <= 30; ++f) {
    sim.StepFrame();
    history.Record(sim);
    ASSERT_EQ(StateHash(sim.state()), first[f]) << "frame " << f;
  }
  // And back again, into the re-simulated part.
  EXPECT_EQ(history.Restore(sim, 29), 29u);
  EXPECT_EQ(StateHash(sim.state()), first[29]);
}

TEST(HistoryTest, StepBackStopsAtTheOldestFrameKept) {
  Simulation sim(SmallDenseScene());
  History history(HistoryConfig{.frames = 10, .max_bytes = size_t{64} << 20, .max_interval = 2});
  history.Start(sim);
  ASSERT_EQ(history.interval(), 1);  // the budget fits all 10 frames
  const std::vector<uint64_t> first = RunAndHash(sim, history, 25);
  EXPECT_EQ(history.oldest_frame(), 15u);
  EXPECT_EQ(history.available(25), 10u);
  EXPECT_EQ(history.Restore(sim, 3), 15u);
  EXPECT_EQ(StateHash(sim.state()), first[15]);
}

TEST(HistoryTest, ParameterChangesArePartOfTheHistory) {
  Simulation sim(SmallDenseScene());
  History history(HistoryConfig{.frames = 40, .max_bytes = size_t{64} << 20, .max_interval = 8});
  history.Start(sim);
  RunAndHash(sim, history, 10);
  const double old_viscosity = sim.params().viscosity;
  ASSERT_FALSE(sim.SetParam("viscosity", 0.05));
  history.RecordParameterChange(sim);
  std::vector<uint64_t> after_change;
  for (int f = 11; f <= 20; ++f) {
    sim.StepFrame();
    history.Record(sim);
    after_change.push_back(StateHash(sim.state()));
  }

  // Back to frame 15: the new viscosity, and the state first simulated with it.
  history.Restore(sim, 15);
  EXPECT_EQ(sim.params().viscosity, 0.05);
  EXPECT_EQ(StateHash(sim.state()), after_change[15 - 11]);
  // Back before the change: the old viscosity again.
  history.Restore(sim, 6);
  EXPECT_EQ(sim.params().viscosity, old_viscosity);
}

TEST(HistoryTest, MemoryStaysWithinTheBudget) {
  Simulation sim(SmallDenseScene());
  const size_t per_checkpoint = sim.SaveCheckpoint().bytes();
  const size_t budget = 6 * per_checkpoint;
  History history(HistoryConfig{.frames = 100, .max_bytes = budget, .max_interval = 4});
  history.Start(sim);
  // 4 checkpoints of the budget's 6 hold the window; 4 frames apart they reach 16 frames back.
  EXPECT_EQ(history.interval(), 4);
  EXPECT_EQ(history.window(), 16u);
  for (int f = 1; f <= 60; ++f) {
    sim.StepFrame();
    history.Record(sim);
    ASSERT_LE(history.bytes(), budget) << "frame " << f;
    if (f % 7 == 0) {  // parameter changes add checkpoints off the interval
      sim.SetParam("viscosity", 0.001 * f);
      history.RecordParameterChange(sim);
      ASSERT_LE(history.bytes(), budget) << "frame " << f;
    }
  }
  EXPECT_GE(history.available(60), 8u);
}

TEST(HistoryTest, TheThesisSceneKeeps600FramesIn256MiB) {
  const Simulation sim(LoadScene("seed_test_scene"));
  ASSERT_EQ(sim.state().particles.size(), 91125u);
  History history;  // the defaults: 600 frames, 256 MiB
  history.Start(sim);
  EXPECT_GE(history.window(), 600u);
  EXPECT_LE(history.interval(), 8);
  // The checkpoints of the whole window, with the two transient ones, fit the budget.
  const size_t most = (history.window() / history.interval() + 2) * sim.SaveCheckpoint().bytes();
  EXPECT_LE(most, size_t{256} << 20);
}

}  // namespace
}  // namespace dysa
