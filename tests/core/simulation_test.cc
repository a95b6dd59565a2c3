// Tests of dysa/core/simulation.h: stepping, time and frames, the per-pass profile, alarms,
// reset, parameter changes, checkpoints, reading particles by id, and runs that are
// deterministic for any thread count (with a golden state hash). The seed solver's own pass
// list and physics are in solvers/seed/seed_solver_test.cc, the spawner's in spawn_test.cc.
#include "dysa/core/simulation.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "dysa/codec/detail_subset.h"
#include "dysa/core/params.h"
#include "dysa/core/scene.h"
#include "support/rank_subset_check.h"
#include "support/with_threads.h"

namespace dysa {
namespace {

// The StateHash of seed_basic with particle_quantity 12 (1,728 particles) after 60 steps
// (GoldenHashTest below). It must only change with an intentional change of the numerics (the
// solver, the kernels, the spawn, the time step): update it then, and say so in the commit.
constexpr uint64_t kGoldenHash = 0xbc314c35fd9bd6a0ull;

using ::testing::Contains;
using ::testing::Not;

Scene BasicScene(int particle_quantity) {
  Scene scene = LoadScene("seed_basic");
  SetParam(scene.params, "particle_quantity", particle_quantity);
  return scene;
}

// 16^3 particles 0.133 m apart with h = 0.2 m: every particle has neighbours from the first
// step, so the density, pressure and viscosity passes all shape the state.
Scene DenseBasicScene() {
  Scene scene = BasicScene(16);
  SetParam(scene.params, "spawn_size", 2.0);
  return scene;
}

std::string HashText(uint64_t hash) {
  char text[32];
  std::snprintf(text, sizeof(text), "0x%016" PRIx64 "ull", hash);
  return text;
}

using dysa::testing::WithThreads;

// ---------------------------------------------------------------------------------------------
// The profile.

TEST(PassListTest, EveryPassIsTimedOncePerStep) {
  Simulation sim(BasicScene(6));
  for (int i = 0; i < 5; ++i) sim.Step();
  for (const PassProfile& pass : sim.profile()) {
    EXPECT_EQ(pass.calls, 5u) << pass.name;
    EXPECT_GE(pass.total_ms, 0) << pass.name;
  }
  sim.ResetProfile();
  for (const PassProfile& pass : sim.profile()) EXPECT_EQ(pass.calls, 0u) << pass.name;
}

// ---------------------------------------------------------------------------------------------
// Stepping, parameters and reset.

TEST(SimulationTest, StepAdvancesTimeByDtAndStepFrameByAFrame) {
  Simulation sim(BasicScene(5));
  EXPECT_EQ(sim.state().particles.size(), 125u);
  const double dt = sim.model().dt;
  EXPECT_DOUBLE_EQ(dt, 1.0 / (60.0 * 3));
  EXPECT_EQ(sim.state().time, 0);
  EXPECT_EQ(sim.state().step, 0u);
  sim.Step();
  EXPECT_EQ(sim.state().step, 1u);
  EXPECT_DOUBLE_EQ(sim.state().time, dt);
  sim.StepFrame();
  EXPECT_EQ(sim.state().step, 4u);
  EXPECT_NEAR(sim.state().time, 4 * dt, 1e-12);
}

TEST(SimulationTest, ANonFiniteStateStopsTheSimulationWithAnAlarm) {
  Simulation sim(BasicScene(6));
  sim.StepFrame();
  EXPECT_EQ(sim.alarm(), "");
  Checkpoint broken = sim.SaveCheckpoint();
  broken.velocity[5].x() = std::numeric_limits<Real>::quiet_NaN();
  sim.RestoreCheckpoint(broken);
  sim.Step();
  EXPECT_THAT(sim.alarm(), ::testing::HasSubstr("non-finite particle state after step"));
  // Stopped: nothing advances until a reset.
  const uint64_t step = sim.state().step;
  const double time = sim.state().time;
  sim.StepFrame();
  sim.Step();
  EXPECT_EQ(sim.state().step, step);
  EXPECT_EQ(sim.state().time, time);
  sim.Reset();
  EXPECT_EQ(sim.alarm(), "");
  sim.StepFrame();
  EXPECT_EQ(sim.alarm(), "");
  EXPECT_TRUE(StateIsFinite(sim.state().particles));
}

TEST(SimulationTest, ResetRestoresTimeStepAndTheInitialState) {
  Simulation sim(BasicScene(8));
  const uint64_t initial = StateHash(sim.state());
  for (int i = 0; i < 20; ++i) sim.Step();
  ASSERT_NE(StateHash(sim.state()), initial);
  sim.Reset();
  EXPECT_EQ(sim.state().time, 0);
  EXPECT_EQ(sim.state().step, 0u);
  EXPECT_EQ(StateHash(sim.state()), initial);
  // And the run after a reset repeats the first one.
  for (int i = 0; i < 20; ++i) sim.Step();
  const uint64_t after_20 = StateHash(sim.state());
  Simulation fresh(BasicScene(8));
  for (int i = 0; i < 20; ++i) fresh.Step();
  EXPECT_EQ(StateHash(fresh.state()), after_20);
}

TEST(SimulationTest, NeedsResetParameterRespawns) {
  Simulation sim(BasicScene(6));
  for (int i = 0; i < 5; ++i) sim.Step();
  EXPECT_TRUE(sim.SetParam("particle_quantity", 7));
  EXPECT_EQ(sim.state().particles.size(), 343u);
  EXPECT_EQ(sim.state().time, 0);
  EXPECT_EQ(sim.state().step, 0u);
  EXPECT_EQ(sim.params().particle_quantity, 7);
  // The state is the fresh spawn of the new parameters.
  EXPECT_EQ(StateHash(sim.state()), StateHash(Simulation(BasicScene(7)).state()));
  // Re-setting the same value is no change and needs no reset.
  sim.Step();
  EXPECT_FALSE(sim.SetParam("particle_quantity", 7));
  EXPECT_EQ(sim.state().step, 1u);
}

TEST(SimulationTest, LiveParameterKeepsTimeStepAndState) {
  Simulation sim(BasicScene(6));
  for (int i = 0; i < 5; ++i) sim.Step();
  const double time = sim.state().time;
  const uint64_t hash = StateHash(sim.state());
  EXPECT_FALSE(sim.SetParam("gravity", -3));
  EXPECT_EQ(sim.params().gravity, -3);
  EXPECT_EQ(sim.state().time, time);
  EXPECT_EQ(sim.state().step, 5u);
  EXPECT_EQ(StateHash(sim.state()), hash);
  // A live change of the time step changes dt.
  EXPECT_FALSE(sim.SetParam("iterations_per_frame", 6));
  EXPECT_DOUBLE_EQ(sim.model().dt, 1.0 / (60.0 * 6));
  EXPECT_EQ(sim.state().step, 5u);
}

TEST(SimulationTest, InvalidParameterThrowsAndChangesNothing) {
  Simulation sim(BasicScene(6));
  for (int i = 0; i < 3; ++i) sim.Step();
  const uint64_t hash = StateHash(sim.state());
  const std::vector<std::string> passes = sim.PassNames();
  const Params before = sim.params();
  for (const auto& [name, value] :
       std::vector<std::pair<std::string, double>>{{"viscosity", -1},
                                                   {"particle_quantity", 0},
                                                   {"particle_quantity", 6.5},
                                                   {"smoothing_radius", std::nan("")},
                                                   {"no_such_param", 1}}) {
    SCOPED_TRACE(name);
    try {
      sim.SetParam(name, value);
      ADD_FAILURE() << "no ConfigError";
    } catch (const ConfigError& e) {
      EXPECT_EQ(e.field(), name);
    }
    for (const ParamDecl& decl : ParamTable()) {
      EXPECT_EQ(decl.get(sim.params()), decl.get(before)) << decl.name;
    }
    EXPECT_EQ(sim.PassNames(), passes);
    EXPECT_EQ(sim.state().step, 3u);
    EXPECT_EQ(StateHash(sim.state()), hash);
  }
}

TEST(SimulationTest, SetParamsValidatesEverythingBeforeApplyingAnything) {
  Simulation sim(BasicScene(6));
  sim.Step();
  const uint64_t hash = StateHash(sim.state());
  Params next = sim.params();
  next.viscosity = 0;          // valid, would remove a pass
  next.particle_quantity = 7;  // valid, would respawn
  next.collision_damping = 2;  // invalid
  EXPECT_THROW(sim.SetParams(next), ConfigError);
  EXPECT_EQ(sim.params().viscosity, 0.001);
  EXPECT_EQ(sim.params().particle_quantity, 6);
  EXPECT_THAT(sim.PassNames(), Contains("viscosity"));
  EXPECT_EQ(StateHash(sim.state()), hash);
  EXPECT_EQ(sim.state().step, 1u);

  next.collision_damping = 0.5;
  EXPECT_TRUE(sim.SetParams(next));
  EXPECT_THAT(sim.PassNames(), Not(Contains("viscosity")));
  EXPECT_EQ(sim.state().particles.size(), 343u);
  EXPECT_EQ(sim.params().collision_damping, 0.5);
}

TEST(SimulationTest, SetParamsRejectsAParticleCountOverTheLimit) {
  Scene scene = ParseScene(R"({"fluid_blocks": [{"particles_per_axis": 2}, {}, {}, {}, {}]})");
  SetParam(scene.params, "particle_quantity", 3);
  Simulation sim(scene);
  EXPECT_EQ(sim.state().particles.size(), 8u + 4 * 27);
  // 8 + 4 x 500^3 = 5e8 + 8 particles, over kMaxParticles: rejected before anything is
  // allocated.
  EXPECT_THROW(sim.SetParam("particle_quantity", 500), ConfigError);
  EXPECT_EQ(sim.params().particle_quantity, 3);
  EXPECT_EQ(sim.state().particles.size(), 116u);
}

TEST(SimulationTest, ReadParticlesByIdOrdersByIdAndChecksSizes) {
  Simulation sim(BasicScene(6));
  for (int i = 0; i < 10; ++i) sim.Step();
  const ParticleArrays& p = sim.state().particles;
  const size_t n = sim.particle_count();
  std::vector<float> position(3 * n), velocity(3 * n), density(n);
  sim.ReadParticlesById({position, velocity, density});
  for (size_t i = 0; i < n; ++i) {
    const size_t k = p.id[i];
    for (int a = 0; a < 3; ++a) {
      ASSERT_EQ(position[3 * k + a], p.position[i][a]);
      ASSERT_EQ(velocity[3 * k + a], p.velocity[i][a]);
    }
    ASSERT_EQ(density[k], p.density[i]);
  }
  std::vector<float> wrong(n);
  EXPECT_THROW(sim.ReadParticlesById({wrong, {}, {}}), std::invalid_argument);
  std::vector<float> positions_only(3 * n);
  sim.ReadParticlesById({positions_only, {}, {}});
  EXPECT_EQ(positions_only, position);
}

// A level of detail's subset (the server's budgeted frames) is the codec's host-side selection
// exactly, with a full read's bits, for nested thresholds and each field alone.
TEST(SimulationTest, ReadParticlesByIdBelowRankIsTheHostSelection) {
  Simulation sim(BasicScene(8));
  for (int i = 0; i < 10; ++i) sim.Step();
  for (double fraction : {0.01, 0.2, 0.5, 0.999}) {
    testing::ExpectSubsetIsTheHostSelection(sim, codec::DetailThreshold(fraction));
  }
  const size_t n = sim.particle_count();
  const uint32_t threshold = codec::DetailThreshold(0.3);
  const testing::SubsetRead all = testing::ReadSubset(sim, threshold);
  std::vector<float> positions_only(3 * n, testing::kUnwritten);
  EXPECT_EQ(sim.ReadParticlesByIdBelowRank(threshold, {positions_only, {}, {}}), all.written);
  EXPECT_EQ(positions_only, all.position);
  std::vector<float> densities_only(n, testing::kUnwritten);
  sim.ReadParticlesByIdBelowRank(threshold, {{}, {}, densities_only});
  EXPECT_EQ(densities_only, all.density);
  // Threshold 0 keeps every particle, as the codec's.
  std::vector<float> full(3 * n), every(3 * n);
  sim.ReadParticlesById({full, {}, {}});
  EXPECT_EQ(sim.ReadParticlesByIdBelowRank(0, {every, {}, {}}), n);
  EXPECT_EQ(every, full);
  std::vector<float> wrong(n);
  EXPECT_THROW(sim.ReadParticlesByIdBelowRank(threshold, {wrong, {}, {}}), std::invalid_argument);
}

TEST(SimulationTest, SpawnIsDeterministicAndIdsAreAPermutation) {
  const Simulation a(BasicScene(9));
  const Simulation b(BasicScene(9));
  EXPECT_EQ(StateHash(a.state()), StateHash(b.state()));
  std::vector<uint32_t> ids = a.state().particles.id;
  std::sort(ids.begin(), ids.end());
  for (size_t i = 0; i < ids.size(); ++i) ASSERT_EQ(ids[i], i);
  // A different jitter seed gives a different state.
  Scene other = BasicScene(9);
  other.fluid_blocks[0].seed = 2;
  EXPECT_NE(StateHash(Simulation(other).state()), StateHash(a.state()));
}

// ---------------------------------------------------------------------------------------------
// Frames in pieces (StepFrame(interrupted)): what lets the server act between steps.

// A small wcsph dam (600 particles): its frames take many CFL-adaptive steps.
Scene PhysicalScene() {
  return ParseScene(R"({
    "domain": {"min": [0, 0, 0], "max": [0.6, 0.4, 0.08]},
    "fluid_blocks": [{"center": [0.1, 0.15, 0.04], "size": [0.2, 0.3, 0.08]}],
    "solver": "wcsph",
    "params": {"gravity": -9.81, "particle_spacing": 0.02, "speed_of_sound": 25}
  })");
}

// Steps one frame interrupting it before every step it can; returns the calls it took.
int StepFrameInSingleSteps(Simulation& sim) {
  int calls = 1;
  const auto always = [] { return true; };
  while (!sim.StepFrame(always)) {
    EXPECT_TRUE(sim.frame_in_progress());
    ++calls;
  }
  EXPECT_FALSE(sim.frame_in_progress());
  return calls;
}

TEST(FrameInPiecesTest, AFrameInterruptedAtEveryStepEndsAsOneSteppedWhole) {
  for (const Scene& scene : {DenseBasicScene(), PhysicalScene()}) {
    SCOPED_TRACE(scene.solver);
    Simulation whole(scene);
    Simulation pieces(scene);
    for (int f = 1; f <= 3; ++f) {
      const uint64_t steps_before = whole.step();
      whole.StepFrame();
      const uint64_t frame_steps = whole.step() - steps_before;
      // One step per call: the frame took as many calls as steps.
      EXPECT_EQ(uint64_t(StepFrameInSingleSteps(pieces)), frame_steps);
      ASSERT_EQ(pieces.frame(), uint64_t(f));
      ASSERT_EQ(pieces.step(), whole.step());
      ASSERT_EQ(pieces.time(), whole.time());  // the same end, to the bit
      ASSERT_EQ(StateHash(pieces.state()), StateHash(whole.state())) << "frame " << f;
    }
    if (scene.solver == "wcsph") {
      EXPECT_GT(whole.step(), 3u * 20);  // many steps per frame
    }
  }
}

TEST(FrameInPiecesTest, APartialFrameCountsNoFrameAndResumesWhereItStopped) {
  Simulation sim(PhysicalScene());
  const double frame_time = sim.model().FrameTime();
  int asked = 0;
  EXPECT_FALSE(sim.StepFrame([&] { return ++asked > 4; }));  // 5 steps, then interrupted
  EXPECT_EQ(asked, 5);  // asked before every step but the first
  EXPECT_EQ(sim.step(), 5u);
  EXPECT_EQ(sim.frame(), 0u);
  EXPECT_TRUE(sim.frame_in_progress());
  EXPECT_LT(sim.time(), frame_time);
  // A parameter change that needs no reset keeps the frame's end (time_scale would move it).
  EXPECT_FALSE(sim.SetParam("time_scale", 0.5));
  EXPECT_TRUE(sim.StepFrame([] { return false; }));
  EXPECT_EQ(sim.frame(), 1u);
  EXPECT_EQ(sim.time(), frame_time);
  // The next frame is half as long.
  sim.StepFrame();
  EXPECT_NEAR(sim.time(), 1.5 * frame_time, 1e-12);
}

// A checkpoint saved into an older one (FrameStepper keeps each long frame's start so) is the
// fresh one's, in the older one's memory.
TEST(CheckpointTest, SavingIntoAnOlderCheckpointReusesItsMemoryAndMatchesAFreshOne) {
  Simulation sim(DenseBasicScene());
  sim.StepFrame();
  Checkpoint reused = sim.SaveCheckpoint();
  const Vec3* memory = reused.position.data();
  sim.StepFrame();
  sim.SaveCheckpoint(reused);
  const Checkpoint fresh = sim.SaveCheckpoint();
  EXPECT_EQ(reused.position.data(), memory);
  EXPECT_EQ(reused.frame, 2u);
  EXPECT_EQ(reused.step, fresh.step);
  EXPECT_EQ(reused.time, fresh.time);
  EXPECT_EQ(reused.id, fresh.id);
  EXPECT_EQ(reused.position, fresh.position);
  EXPECT_EQ(reused.velocity, fresh.velocity);
  EXPECT_EQ(reused.solver_arrays.size(), fresh.solver_arrays.size());
  // And it restores to the same state.
  const uint64_t at_frame_2 = StateHash(sim.state());
  sim.StepFrame();
  sim.RestoreCheckpoint(reused);
  EXPECT_EQ(StateHash(sim.state()), at_frame_2);
}

TEST(FrameInPiecesTest, ResetAndRestoringACheckpointDropAPartialFrame) {
  Simulation sim(DenseBasicScene());
  const int steps_per_frame = sim.params().iterations_per_frame;
  ASSERT_GE(steps_per_frame, 2);
  sim.StepFrame();
  const Checkpoint at_frame_1 = sim.SaveCheckpoint();
  sim.StepFrame();
  const uint64_t hash_at_frame_2 = StateHash(sim.state());

  const auto stop = [] { return true; };
  ASSERT_FALSE(sim.StepFrame(stop));  // one step into frame 3
  sim.RestoreCheckpoint(at_frame_1);
  EXPECT_FALSE(sim.frame_in_progress());
  // A whole frame from the checkpoint, not the rest of the dropped one.
  EXPECT_EQ(StepFrameInSingleSteps(sim), steps_per_frame);
  EXPECT_EQ(sim.frame(), 2u);
  EXPECT_EQ(StateHash(sim.state()), hash_at_frame_2);

  ASSERT_FALSE(sim.StepFrame(stop));
  sim.Reset();
  EXPECT_FALSE(sim.frame_in_progress());
  EXPECT_EQ(StepFrameInSingleSteps(sim), steps_per_frame);
  EXPECT_EQ(sim.step(), uint64_t(steps_per_frame));

  // So does a parameter change that resets.
  ASSERT_FALSE(sim.StepFrame(stop));
  ASSERT_TRUE(sim.SetParam("particle_quantity", 10));
  EXPECT_FALSE(sim.frame_in_progress());
  EXPECT_EQ(StepFrameInSingleSteps(sim), steps_per_frame);
}

// ---------------------------------------------------------------------------------------------
// Determinism.

uint64_t HashAfter(const Scene& scene, int steps) {
  Simulation sim(scene);
  for (int i = 0; i < steps; ++i) sim.Step();
  return StateHash(sim.state());
}

TEST(DeterminismTest, SameHashWithOneTwoAndThreeThreads) {
  const Scene scene = DenseBasicScene();
  const uint64_t one = WithThreads(1, [&] { return HashAfter(scene, 60); });
  const uint64_t two = WithThreads(2, [&] { return HashAfter(scene, 60); });
  const uint64_t three = WithThreads(3, [&] { return HashAfter(scene, 60); });
  EXPECT_EQ(one, two) << HashText(one) << " vs " << HashText(two);
  EXPECT_EQ(one, three) << HashText(one) << " vs " << HashText(three);
}

TEST(DeterminismTest, SameHashWithThreadsForObstaclesAndViscosity) {
  // A dense 9^3 block thrown at the sphere, which it reaches after about 18 steps.
  Scene scene = LoadScene("seed_obstacles");
  scene.fluid_blocks[0].center = Vec3d(-1.2, -1.6, 0.8);
  scene.fluid_blocks[0].size = Vec3d::Constant(1.2);
  scene.fluid_blocks[0].particles_per_axis = Eigen::Vector3i(9, 9, 9);
  SetParam(scene.params, "viscosity", 0.01);
  const uint64_t one = WithThreads(1, [&] { return HashAfter(scene, 60); });
  const uint64_t two = WithThreads(2, [&] { return HashAfter(scene, 60); });
  EXPECT_EQ(one, two) << HashText(one) << " vs " << HashText(two);
}

TEST(DeterminismTest, GoldenHash) {
  // If this fails after an intentional change of the numerics, replace kGoldenHash at the top
  // of this file with the value printed here.
  const uint64_t hash = HashAfter(DenseBasicScene(), 60);
  EXPECT_EQ(hash, kGoldenHash) << "StateHash after 60 steps of seed_basic with "
                               << "particle_quantity 16, spawn_size 2 is " << HashText(hash);
}

}  // namespace
}  // namespace dysa
