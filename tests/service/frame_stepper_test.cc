// Tests of dysa/service/frame_stepper.h on a bare Simulation: a frame's start is kept while
// frames are expected to outlast half the landing budget, rolling back returns to it bit for bit
// with the current parameters, and the frame stepped again from there ends as one stepped whole.
#include "dysa/service/frame_stepper.h"

#include <gtest/gtest.h>

#include <chrono>

namespace dysa::service {
namespace {

using namespace std::chrono_literals;

// 8^3 particles of the thesis's basic set-up, 6 fixed steps a frame.
Scene SeedScene() {
  Scene scene = LoadScene("seed_basic");
  SetParam(scene.params, "particle_quantity", 8);
  SetParam(scene.params, "spawn_size", 1.2);
  SetParam(scene.params, "iterations_per_frame", 6);
  return scene;
}

// Interrupts StepFrame after `steps` more steps.
auto After(int steps) {
  return [steps]() mutable { return --steps < 0; };
}

TEST(FrameStepperTest, RollingBackReturnsToTheFramesStartAndTheFrameEndsAsOneSteppedWhole) {
  Simulation sim(SeedScene());
  Simulation whole(SeedScene());
  FrameStepper stepper(0ms);  // every frame of more than one step is expected to be too long
  ASSERT_TRUE(stepper.Advance(sim, [] { return false; }));
  whole.StepFrame();
  const uint64_t at_frame = StateHash(sim.state());

  ASSERT_FALSE(stepper.Advance(sim, After(2)));
  ASSERT_TRUE(sim.frame_in_progress());
  EXPECT_EQ(sim.step(), 6u + 3);
  ASSERT_TRUE(stepper.CanRollBack(sim));
  EXPECT_FALSE(stepper.ExpectFinishedBy(sim, FrameStepper::Clock::now()));
  stepper.RollBack(sim);
  EXPECT_FALSE(sim.frame_in_progress());
  EXPECT_EQ(sim.frame(), 1u);
  EXPECT_EQ(sim.step(), 6u);
  EXPECT_EQ(StateHash(sim.state()), at_frame);

  // In pieces again, then whole: the same bits as a frame never interrupted.
  ASSERT_FALSE(stepper.Advance(sim, After(1)));
  ASSERT_TRUE(stepper.Advance(sim, [] { return false; }));
  whole.StepFrame();
  EXPECT_EQ(sim.step(), whole.step());
  EXPECT_EQ(StateHash(sim.state()), StateHash(whole.state()));
}

TEST(FrameStepperTest, ARollBackKeepsTheParametersChangedInsideTheFrame) {
  Simulation sim(SeedScene());
  FrameStepper stepper(0ms);
  ASSERT_FALSE(stepper.Advance(sim, After(2)));
  ASSERT_FALSE(sim.SetParam("gravity", -2.0));
  stepper.RollBack(sim);
  EXPECT_EQ(sim.step(), 0u);
  EXPECT_EQ(sim.params().gravity, -2.0);
  // The frame from its start with the new gravity, as a simulation that had it from the start.
  Scene changed = SeedScene();
  SetParam(changed.params, "gravity", -2.0);
  Simulation expected(changed);
  expected.StepFrame();
  ASSERT_TRUE(stepper.Advance(sim, [] { return false; }));
  EXPECT_EQ(StateHash(sim.state()), StateHash(expected.state()));
}

// The rule, in numbers (a 100 ms budget).
TEST(FrameStepperTest, AStartIsKeptWhenTheTailOutlastsTheBudgetOrKeepingIsCheap) {
  EXPECT_TRUE(FrameStepper::WorthKeeping(0.150, 0.160, 10.0, 0.1));   // late otherwise: always
  EXPECT_FALSE(FrameStepper::WorthKeeping(0.040, 0.050, 0.0, 0.1));   // fits half the budget
  EXPECT_TRUE(FrameStepper::WorthKeeping(0.080, 0.090, 0.0, 0.1));    // not measured yet
  EXPECT_TRUE(FrameStepper::WorthKeeping(0.080, 0.090, 0.020, 0.1));  // 22% of the frame
  // A frame of 96 ms, 84 after its first step, whose copy takes 290 ms.
  EXPECT_FALSE(FrameStepper::WorthKeeping(0.084, 0.096, 0.290, 0.1));
}

TEST(FrameStepperTest, AFrameExpectedToFitTheBudgetKeepsNoStartAndIsFinished) {
  Simulation sim(SeedScene());
  FrameStepper stepper(1h);
  // Nothing measured yet: the first frame's start is kept, whatever the budget.
  ASSERT_FALSE(stepper.Advance(sim, After(1)));
  EXPECT_TRUE(stepper.CanRollBack(sim));
  ASSERT_TRUE(stepper.Advance(sim, [] { return false; }));
  EXPECT_FALSE(stepper.CanRollBack(sim));  // no frame in progress
  EXPECT_GT(stepper.step_seconds(), 0.0);
  // Measured: six steps of a few hundred particles are far inside an hour.
  ASSERT_FALSE(stepper.Advance(sim, After(1)));
  EXPECT_FALSE(stepper.CanRollBack(sim));
  EXPECT_TRUE(stepper.ExpectFinishedBy(sim, FrameStepper::Clock::now() + 1h));
  EXPECT_DOUBLE_EQ(sim.FrameStepsLeft(), 4.0);
  // A new scene forgets the measurements: its first frame is kept again.
  ASSERT_TRUE(stepper.Advance(sim, [] { return false; }));
  stepper.Forget();
  ASSERT_FALSE(stepper.Advance(sim, After(1)));
  EXPECT_TRUE(stepper.CanRollBack(sim));
}

}  // namespace
}  // namespace dysa::service
