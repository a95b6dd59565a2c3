// The conformance suite: what every registered solver must do on every device, whatever its
// physics. Built twice: solver_conformance_test (the CPU) and solver_conformance_gpu_test (cuda:0,
// ctest label gpu; every test skips, printing why, where no CUDA GPU can run).
//   - a run is deterministic: the same scene twice gives the same state hash (and, on the CPU,
//     the same with 1 and 2 threads);
//   - a checkpoint round-trips: restored, the following frames repeat bit for bit;
//   - stress basics: a block falling in a closed box stays finite, inside the domain, without an
//     alarm, and moves;
//   - reset respawns the initial state.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "dysa/core/device.h"
#include "dysa/core/neighbor_grid.h"
#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "dysa/core/solver.h"
#include "stress/stress_cases.h"
#include "support/with_threads.h"

namespace dysa {
namespace {

#ifdef DYSA_CONFORMANCE_ON_CUDA
const Device kDevice{Device::Kind::kCuda, 0};
#else
const Device kDevice{};
#endif

class SolverConformanceTest : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    const std::string reason = DeviceUnavailableReason(kDevice);
    if (!reason.empty()) GTEST_SKIP() << "cannot run on " << kDevice.ToString() << ": " << reason;
  }
  // The stress suite's base scene of this solver: a small block falling in a closed box.
  Scene BlockScene() const { return stress::BaseScene(FindSolver(GetParam())); }
};

uint64_t HashAfterFrames(const Scene& scene, int frames) {
  Simulation sim(scene, kDevice);
  for (int f = 0; f < frames; ++f) sim.StepFrame();
  EXPECT_EQ(sim.alarm(), "");
  return StateHash(sim.state());
}

TEST_P(SolverConformanceTest, ARunIsDeterministic) {
  const Scene scene = BlockScene();
  const uint64_t first = HashAfterFrames(scene, 6);
  EXPECT_EQ(HashAfterFrames(scene, 6), first);
  EXPECT_NE(first, StateHash(Simulation(scene, kDevice).state())) << "nothing moved";
  if (!kDevice.is_cuda()) {
    using dysa::testing::WithThreads;
    EXPECT_EQ(WithThreads(1, [&] { return HashAfterFrames(scene, 6); }), first);
    EXPECT_EQ(WithThreads(2, [&] { return HashAfterFrames(scene, 6); }), first);
  }
}

TEST_P(SolverConformanceTest, ACheckpointRoundTrips) {
  Simulation sim(BlockScene(), kDevice);
  for (int f = 0; f < 3; ++f) sim.StepFrame();
  const Checkpoint checkpoint = sim.SaveCheckpoint();
  for (int f = 0; f < 3; ++f) sim.StepFrame();
  const uint64_t hash = StateHash(sim.state());
  const double time = sim.time();
  const uint64_t steps = sim.step();
  sim.RestoreCheckpoint(checkpoint);
  EXPECT_EQ(sim.frame(), 3u);
  for (int f = 0; f < 3; ++f) sim.StepFrame();
  EXPECT_EQ(StateHash(sim.state()), hash);
  EXPECT_EQ(sim.time(), time);
  EXPECT_EQ(sim.step(), steps);
}

TEST_P(SolverConformanceTest, AFallingBlockStaysFiniteAndInside) {
  Simulation sim(BlockScene(), kDevice);
  const uint64_t initial = StateHash(sim.state());
  for (int f = 0; f < 20; ++f) {
    sim.StepFrame();
    ASSERT_EQ(sim.alarm(), "") << "frame " << f;
  }
  const State& state = sim.state();
  EXPECT_TRUE(StateIsFinite(state.particles));
  const Aabb& domain = sim.model().domain;
  for (const Vec3& x : state.particles.position) {
    ASSERT_TRUE(domain.Contains(x.cast<double>())) << x.transpose();
  }
  EXPECT_NE(StateHash(state), initial);
  EXPECT_GT(stress::KineticEnergy(sim), 0);
}

TEST_P(SolverConformanceTest, ResetRespawnsTheInitialState) {
  Simulation sim(BlockScene(), kDevice);
  const uint64_t initial = StateHash(sim.state());
  for (int f = 0; f < 2; ++f) sim.StepFrame();
  sim.Reset();
  EXPECT_EQ(sim.time(), 0);
  EXPECT_EQ(sim.step(), 0u);
  EXPECT_EQ(StateHash(sim.state()), initial);
}

// Particles collapsed to one point (a valid checkpoint of any scene): every neighbour pass
// would test every pair, O(n^2). The neighbour sort finds the crowded cell and the step stops
// with an alarm naming the limit (on the CPU before the neighbour passes, the state as it was;
// on a GPU after the first of them, or after the seed's whole step); nothing advances until a
// reset.
TEST_P(SolverConformanceTest, ParticlesCrowdedIntoOneCellRaiseTheAlarm) {
  Scene scene = ParseScene(R"({
    "domain": {"min": [0, 0, 0], "max": [0.4, 0.4, 0.4]},
    "fluid_blocks": [{"center": [0.2, 0.2, 0.2], "size": [0.3, 0.3, 0.3]}],
    "params": {"particle_spacing": 0.02, "particle_quantity": 15}
  })");
  scene.solver = GetParam();
  Simulation sim(scene, kDevice);
  ASSERT_GT(sim.particle_count(), size_t(NeighborGrid::kMaxParticlesPerCell));
  sim.Step();
  ASSERT_EQ(sim.alarm(), "");
  Checkpoint collapsed = sim.SaveCheckpoint();
  for (Vec3& x : collapsed.position) x = Vec3(0.3f, 0.3f, 0.3f);  // inside one cell
  sim.RestoreCheckpoint(collapsed);
  const double before = sim.time();
  sim.Step();
  EXPECT_THAT(sim.alarm(), ::testing::HasSubstr("particles crowd one neighbour-grid cell"));
  EXPECT_THAT(sim.alarm(),
              ::testing::HasSubstr(std::to_string(NeighborGrid::kMaxParticlesPerCell)));
  if (!kDevice.is_cuda()) {
    EXPECT_EQ(sim.time(), before);  // stopped before the neighbour passes
  }
  const double time = sim.time();
  sim.StepFrame();
  EXPECT_EQ(sim.time(), time);
  sim.Reset();
  EXPECT_EQ(sim.alarm(), "");
  sim.Step();
  EXPECT_EQ(sim.alarm(), "");
}

std::vector<std::string> RegisteredSolvers() {
  std::vector<std::string> names;
  for (const SolverInfo& info : SolverRegistry()) names.emplace_back(info.name);
  return names;
}

INSTANTIATE_TEST_SUITE_P(EverySolver, SolverConformanceTest,
                         ::testing::ValuesIn(RegisteredSolvers()),
                         [](const ::testing::TestParamInfo<std::string>& param) {
                           return param.param;
                         });

}  // namespace
}  // namespace dysa
