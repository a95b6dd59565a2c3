// Tests of the seed solver's CUDA backend (server/core/src/cuda/seed_pipeline.cu) through
// Simulation: the GPU's state is bit-identical to the CPU's after every pass list a scene can
// build, two GPU runs are bit-identical, checkpoints round-trip through device memory, and the
// alarm and warning checks act as on the CPU. ctest label `gpu`: every test skips, printing
// why, where no CUDA GPU can run (a build without CUDA, no driver, no GPU).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cinttypes>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "dysa/core/device.h"
#include "dysa/core/probes.h"
#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "support/gpu_test.h"

namespace dysa {
namespace {

using dysa::testing::kGpu;

std::string HashText(uint64_t hash) {
  char text[32];
  std::snprintf(text, sizeof(text), "0x%016" PRIx64, hash);
  return text;
}

Scene BasicScene(int particle_quantity) {
  Scene scene = LoadScene("seed_basic");
  SetParam(scene.params, "particle_quantity", particle_quantity);
  return scene;
}

// The dense block of simulation_test's golden hash: every pass shapes the state.
Scene DenseScene() {
  Scene scene = BasicScene(16);
  SetParam(scene.params, "spawn_size", 2.0);
  return scene;
}

Scene ObstacleScene() {
  Scene scene = LoadScene("seed_obstacles");
  scene.fluid_blocks[0].center = Vec3d(-1.2, -1.6, 0.8);
  scene.fluid_blocks[0].size = Vec3d::Constant(1.2);
  scene.fluid_blocks[0].particles_per_axis = Eigen::Vector3i(9, 9, 9);
  SetParam(scene.params, "viscosity", 0.01);
  return scene;
}

Scene PeriodicScene() {
  return ParseScene(R"({
    "domain": {"min": [-1, -1, -1], "max": [1, 1, 1], "periodic": [true, false, true]},
    "fluid_blocks": [{"center": [0.5, -0.4, 0.7], "size": 1.0, "particles_per_axis": 10,
                      "jitter": 0.03, "velocity": [3, 0, -2]}],
    "params": {"smoothing_radius": 0.2}
  })");
}

// Two identical blocks without jitter: every particle has a twin at distance 0, which takes
// the coincident-pair directions of the pressure force.
Scene CoincidentScene() {
  return ParseScene(R"({
    "fluid_blocks": [{"center": [0, 0, 0], "size": 0.4, "particles_per_axis": 5, "jitter": 0},
                     {"center": [0, 0, 0], "size": 0.4, "particles_per_axis": 5, "jitter": 0}]
  })");
}

uint64_t HashAfter(const Scene& scene, const Device& device, int steps) {
  Simulation sim(scene, device);
  for (int i = 0; i < steps; ++i) sim.Step();
  EXPECT_EQ(sim.alarm(), "");
  return StateHash(sim.state());
}

void ExpectBitIdentical(const Scene& scene, int steps) {
  const uint64_t cpu = HashAfter(scene, Device{}, steps);
  const uint64_t gpu = HashAfter(scene, kGpu, steps);
  EXPECT_EQ(cpu, gpu) << "CPU " << HashText(cpu) << " vs GPU " << HashText(gpu) << " after "
                      << steps << " steps";
}

TEST(SeedGpuTest, BitIdenticalToTheCpuOnTheDenseBlock) {
  SKIP_WITHOUT_GPU();
  ExpectBitIdentical(DenseScene(), 60);
}

TEST(SeedGpuTest, BitIdenticalToTheCpuOnTheThesisScene) {
  SKIP_WITHOUT_GPU();
  ExpectBitIdentical(BasicScene(30), 180);  // 27,000 particles, 1 s
}

TEST(SeedGpuTest, BitIdenticalWithoutNearPressureOrViscosity) {
  SKIP_WITHOUT_GPU();
  Scene no_near = DenseScene();
  SetParam(no_near.params, "near_pressure_multiplier", 0);
  ExpectBitIdentical(no_near, 60);
  Scene no_viscosity = DenseScene();
  SetParam(no_viscosity.params, "viscosity", 0);
  ExpectBitIdentical(no_viscosity, 60);
}

TEST(SeedGpuTest, BitIdenticalWithObstaclesPeriodicAxesAndCoincidentParticles) {
  SKIP_WITHOUT_GPU();
  ExpectBitIdentical(ObstacleScene(), 90);
  ExpectBitIdentical(PeriodicScene(), 90);
  ExpectBitIdentical(CoincidentScene(), 30);
}

// The obstacle scene with both obstacles moving (the sphere along a keyframed path into the
// block, the box sliding back and forth): each step collides at where the step leaves them,
// reflecting the velocity relative to them, bit for bit as on the CPU.
TEST(SeedGpuTest, BitIdenticalWithMovingObstacles) {
  SKIP_WITHOUT_GPU();
  Scene scene = ObstacleScene();
  scene.spheres.at(0).motion.keys = {{0, Vec3d::Zero()}, {0.2, Vec3d(-1.5, 0.5, 0)}};
  scene.boxes.at(0).motion.keys = {
      {0.05, Vec3d::Zero()}, {0.25, Vec3d(-1, 0, 0)}, {0.4, Vec3d(-0.5, 0, 0.3)}};
  ExpectBitIdentical(scene, 90);
}

TEST(SeedGpuTest, TwoRunsAreBitIdentical) {
  SKIP_WITHOUT_GPU();
  const uint64_t first = HashAfter(ObstacleScene(), kGpu, 60);
  const uint64_t second = HashAfter(ObstacleScene(), kGpu, 60);
  EXPECT_EQ(first, second) << HashText(first) << " vs " << HashText(second);
}

TEST(SeedGpuTest, PassesAreTheCpusAndEachIsTimed) {
  SKIP_WITHOUT_GPU();
  Simulation cpu(ObstacleScene());
  Simulation gpu(ObstacleScene(), kGpu);
  EXPECT_EQ(gpu.PassNames(), cpu.PassNames());
  for (int i = 0; i < 3; ++i) gpu.Step();
  for (const PassProfile& pass : gpu.profile()) {
    EXPECT_EQ(pass.calls, 3u) << pass.name;
    EXPECT_GT(pass.total_ms, 0) << pass.name;
  }
  EXPECT_GT(gpu.DeviceBytes(), 0u);
  // A parameter change rebuilds the GPU's pass list as the CPU's.
  gpu.SetParam("viscosity", 0);
  cpu.SetParam("viscosity", 0);
  EXPECT_EQ(gpu.PassNames(), cpu.PassNames());
}

TEST(SeedGpuTest, CheckpointsRoundTripThroughDeviceMemory) {
  SKIP_WITHOUT_GPU();
  Simulation sim(DenseScene(), kGpu);
  for (int i = 0; i < 20; ++i) sim.Step();
  const Checkpoint at20 = sim.SaveCheckpoint();
  for (int i = 0; i < 20; ++i) sim.Step();
  const uint64_t at40 = StateHash(sim.state());
  sim.RestoreCheckpoint(at20);
  EXPECT_EQ(sim.step(), 20u);
  for (int i = 0; i < 20; ++i) sim.Step();
  EXPECT_EQ(StateHash(sim.state()), at40);
  // And a CPU simulation restored from the GPU's checkpoint carries on identically.
  Simulation cpu(DenseScene());
  cpu.RestoreCheckpoint(at20);
  for (int i = 0; i < 20; ++i) cpu.Step();
  EXPECT_EQ(StateHash(cpu.state()), at40);
}

TEST(SeedGpuTest, ResetRespawnsOnTheDevice) {
  SKIP_WITHOUT_GPU();
  Simulation sim(DenseScene(), kGpu);
  const uint64_t initial = StateHash(sim.state());
  for (int i = 0; i < 10; ++i) sim.Step();
  ASSERT_NE(StateHash(sim.state()), initial);
  sim.Reset();
  EXPECT_EQ(StateHash(sim.state()), initial);
  for (int i = 0; i < 10; ++i) sim.Step();
  EXPECT_EQ(StateHash(sim.state()), HashAfter(DenseScene(), Device{}, 10));
}

TEST(SeedGpuTest, ANonFiniteStateRaisesTheAlarm) {
  SKIP_WITHOUT_GPU();
  Simulation sim(BasicScene(6), kGpu);
  sim.StepFrame();
  Checkpoint broken = sim.SaveCheckpoint();
  broken.velocity[5].x() = std::numeric_limits<Real>::quiet_NaN();
  sim.RestoreCheckpoint(broken);
  sim.Step();
  EXPECT_THAT(sim.alarm(), ::testing::HasSubstr("non-finite particle state after step"));
  const uint64_t step = sim.step();
  sim.Step();
  EXPECT_EQ(sim.step(), step);
  sim.Reset();
  sim.StepFrame();
  EXPECT_EQ(sim.alarm(), "");
}

TEST(SeedGpuTest, TheVelocityLimiterWarnsAsOnTheCpu) {
  SKIP_WITHOUT_GPU();
  // Far too stiff for the step: particles are thrown apart faster than h / dt.
  Scene scene = DenseScene();
  SetParam(scene.params, "pressure_multiplier", 5000);
  SetParam(scene.params, "time_scale", 3);
  Simulation cpu(scene);
  Simulation gpu(scene, kGpu);
  cpu.StepFrame();
  gpu.StepFrame();
  ASSERT_THAT(cpu.warning(), ::testing::HasSubstr("velocity limiter"));
  EXPECT_EQ(gpu.warning(), cpu.warning());
  EXPECT_EQ(StateHash(gpu.state()), StateHash(cpu.state()));
}

TEST(SeedGpuTest, ProbesReadTheDevicesState) {
  SKIP_WITHOUT_GPU();
  const Scene scene = BasicScene(12);
  Simulation cpu(scene);
  Simulation gpu(scene, kGpu);
  for (int i = 0; i < 30; ++i) cpu.StepFrame(), gpu.StepFrame();
  EXPECT_EQ(EvaluateProbes(scene.probes, gpu.model(), gpu.state()),
            EvaluateProbes(scene.probes, cpu.model(), cpu.state()));
}

TEST(SeedGpuTest, FramesAndCheckpointsReadOnlyWhatTheyNeedInIdOrder) {
  SKIP_WITHOUT_GPU();
  const Scene scene = BasicScene(10);
  Simulation cpu(scene);
  Simulation gpu(scene, kGpu);
  for (int i = 0; i < 20; ++i) cpu.Step(), gpu.Step();
  const size_t n = cpu.particle_count();
  std::vector<float> pc(3 * n), vc(3 * n), dc(n), pg(3 * n), vg(3 * n), dg(n);
  cpu.ReadParticlesById({pc, vc, dc});
  gpu.ReadParticlesById({pg, vg, dg});  // from device memory, without state()
  EXPECT_EQ(pg, pc);
  EXPECT_EQ(vg, vc);
  EXPECT_EQ(dg, dc);
  std::vector<float> positions_only(3 * n);
  gpu.ReadParticlesById({positions_only, {}, {}});
  EXPECT_EQ(positions_only, pc);
  // A checkpoint of the device's state restores on the CPU and carries on identically.
  const Checkpoint saved = gpu.SaveCheckpoint();
  Simulation resumed(scene);
  resumed.RestoreCheckpoint(saved);
  for (int i = 0; i < 10; ++i) resumed.Step(), gpu.Step();
  EXPECT_EQ(StateHash(resumed.state()), StateHash(gpu.state()));
}

}  // namespace
}  // namespace dysa
