// Tests of wcsph's predictor-corrector (server/core/src/solvers/wcsph/symplectic.cc): its pass
// list, second order in the step where the symplectic Euler step is first order, the same bits
// for any thread count, checkpoints that resume bit for bit, and a switch between the two
// integrations in the middle of a run.
#include "solvers/wcsph/symplectic.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "dysa/core/state.h"
#include "support/with_threads.h"

namespace dysa {
namespace {

using dysa::testing::WithThreads;

// A 0.2 x 0.3 m column of water, 4 particles thick, released in a 0.6 x 0.4 m tank (600
// particles), with the step fixed at `dt` (cfl_factor 1 leaves the CFL limit at 8e-4 s, above
// every dt used here).
Scene Column(int integration, double dt) {
  Scene scene = ParseScene(R"({
    "domain": {"min": [0, 0, 0], "max": [0.6, 0.4, 0.08]},
    "fluid_blocks": [{"center": [0.1, 0.15, 0.04], "size": [0.2, 0.3, 0.08]}],
    "solver": "wcsph",
    "params": {"gravity": -9.81, "particle_spacing": 0.02, "speed_of_sound": 25,
               "kinematic_viscosity": 1e-5, "cfl_factor": 1}
  })");
  SetParam(scene.params, "time_integration", integration);
  SetParam(scene.params, "max_time_step", dt);
  return scene;
}

// Positions in id order after `seconds` of flow.
std::vector<Vec3d> PositionsAfter(const Scene& scene, double seconds) {
  Simulation sim(scene);
  while (sim.time() < seconds) sim.Step(seconds);
  const ParticleArrays& p = sim.state().particles;
  std::vector<Vec3d> by_id(p.size());
  for (size_t k = 0; k < p.size(); ++k) by_id.at(p.id[k]) = p.position[k].cast<double>();
  return by_id;
}

double RmsDistance(const std::vector<Vec3d>& a, const std::vector<Vec3d>& b) {
  double sum = 0;
  for (size_t k = 0; k < a.size(); ++k) sum += (a[k] - b[k]).squaredNorm();
  return std::sqrt(sum / double(a.size()));
}

TEST(SymplecticPassListTest, RepeatsTheForcePassesAtTheHalfStep) {
  const Simulation sim(Column(1, 1e-4));
  const std::vector<std::string> expected = {"neighbour_grid",
                                             "pressure",
                                             "boundary_pressure",
                                             "interactions",
                                             "time_step",
                                             "predict",
                                             "neighbour_grid_corrector",
                                             "pressure_corrector",
                                             "boundary_pressure_corrector",
                                             "interactions_corrector",
                                             "correct"};
  EXPECT_EQ(sim.PassNames(), expected);
  EXPECT_EQ(Simulation(Column(0, 1e-4)).PassNames().back(), "integrate");
}

// RMS distance between the runs at dt and at dt / 2 after 51.2 ms of the column's release (the
// pressure settling, the first acceleration), for dt in `steps`: Richardson's estimate of the
// error at each step, without a reference run (one of a step fine enough for it would be
// dominated by float rounding: positions gain a few nm per step).
std::vector<double> StepHalvingDifferences(int integration, const std::vector<double>& steps) {
  const double seconds = 0.0512;  // a multiple of every step
  std::vector<std::vector<Vec3d>> runs;
  for (const double dt : steps) runs.push_back(PositionsAfter(Column(integration, dt), seconds));
  std::vector<double> differences;
  for (size_t k = 0; k + 1 < runs.size(); ++k) {
    differences.push_back(RmsDistance(runs[k], runs[k + 1]));
  }
  return differences;
}

// Halving the step divides the predictor-corrector's error by about 4 (measured 3.9 from
// 6.4e-4 s; below 1.6e-4 s it reaches the float rounding floor of about 5e-7 m) and the
// symplectic Euler step's by about 2 (2.2 from 1.6e-4 s); at 3.2e-4 s the first is 70 times
// the more accurate.
TEST(SymplecticConvergenceTest, IsSecondOrderInTheStepWhereEulerIsFirst) {
  const std::vector<double> corrector = StepHalvingDifferences(1, {6.4e-4, 3.2e-4, 1.6e-4});
  const std::vector<double> euler = StepHalvingDifferences(0, {3.2e-4, 1.6e-4, 8e-5, 4e-5});
  SCOPED_TRACE("predictor-corrector " + std::to_string(corrector[0]) + ", " +
               std::to_string(corrector[1]) + " m; Euler " + std::to_string(euler[0]) + ", " +
               std::to_string(euler[1]) + ", " + std::to_string(euler[2]) + " m");
  EXPECT_GT(corrector[0] / corrector[1], 3.2);
  EXPECT_GT(euler[1] / euler[2], 1.6);
  EXPECT_LT(euler[1] / euler[2], 2.6);
  EXPECT_LT(corrector[1], euler[0] / 20);
}

TEST(SymplecticDeterminismTest, SameBitsForAnyThreadCount) {
  const auto hash_after = [](int threads) {
    return WithThreads(threads, [] {
      Simulation sim(Column(1, 0.005));
      for (int k = 0; k < 40; ++k) sim.Step();
      return StateHash(sim.state());
    });
  };
  EXPECT_EQ(hash_after(1), hash_after(2));
}

// A checkpoint holds everything the next step needs: the step's start is scratch of the step
// itself, not state.
TEST(SymplecticCheckpointTest, RestoredRunsContinueBitForBit) {
  Simulation sim(Column(1, 0.005));
  for (int k = 0; k < 20; ++k) sim.Step();
  const Checkpoint checkpoint = sim.SaveCheckpoint();
  for (int k = 0; k < 20; ++k) sim.Step();
  const uint64_t expected = StateHash(sim.state());
  sim.RestoreCheckpoint(checkpoint);
  for (int k = 0; k < 20; ++k) sim.Step();
  EXPECT_EQ(StateHash(sim.state()), expected);
}

// time_integration is live: switching mid-run rebuilds the pass list and keeps the particles.
TEST(SymplecticSwitchTest, SwitchingMidRunKeepsTheStateAndChangesThePasses) {
  Simulation sim(Column(0, 0.005));
  for (int k = 0; k < 10; ++k) sim.Step();
  const uint64_t before = StateHash(sim.state());
  EXPECT_FALSE(sim.SetParam("time_integration", 1));  // no reset
  EXPECT_EQ(StateHash(sim.state()), before);
  EXPECT_EQ(sim.PassNames().back(), "correct");
  const double time = sim.time();
  for (int k = 0; k < 10; ++k) sim.Step();
  EXPECT_GT(sim.time(), time);
  EXPECT_TRUE(sim.alarm().empty()) << sim.alarm();
}

}  // namespace
}  // namespace dysa
