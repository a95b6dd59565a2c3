// Tests of the level of detail's subset chosen on the GPU (server/core/src/cuda/rank_subset.cu)
// through Simulation::ReadParticlesByIdBelowRank, for the three solvers' CUDA backends: the
// device picks exactly the particles of the codec's host-side selection (codec::KeptIds), the
// same as the CPU's subset of the same run, with the bits of a full read of the device's state;
// its cached table follows a new threshold, a return to an old one and a new particle count.
// ctest label `gpu`: every test skips, printing why, where no CUDA GPU can run (a build without
// CUDA, no driver, no GPU).
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "dysa/codec/detail_subset.h"
#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "support/gpu_test.h"
#include "support/rank_subset_check.h"

namespace dysa {
namespace {

using dysa::testing::ExpectSubsetIsTheHostSelection;
using dysa::testing::kGpu;
using dysa::testing::kUnwritten;
using dysa::testing::ReadSubset;
using dysa::testing::SubsetRead;

Scene SceneOf(const std::string& solver) {
  if (solver != "seed") return dysa::testing::DamScene(solver);
  Scene scene = LoadScene("seed_basic");
  SetParam(scene.params, "particle_quantity", 10);
  return scene;
}

// The entries a subset read wrote: where the sentinel is not.
std::vector<bool> Written(const SubsetRead& r) {
  std::vector<bool> written(r.density.size());
  for (size_t k = 0; k < written.size(); ++k) written[k] = r.position[3 * k] != kUnwritten;
  return written;
}

class RankSubsetGpuTest : public ::testing::TestWithParam<std::string> {};

// After steps on both devices, the GPU's subset (read from device memory: neither simulation's
// state() is asked for) is the codec's selection for nested thresholds from 1 % to 99.9 %, and
// the CPU's subset of its own run writes the same particles.
TEST_P(RankSubsetGpuTest, TheDeviceChoosesTheHostSelection) {
  SKIP_WITHOUT_GPU();
  const Scene scene = SceneOf(GetParam());
  Simulation cpu(scene);
  Simulation gpu(scene, kGpu);
  for (int i = 0; i < 5; ++i) cpu.Step(), gpu.Step();
  ASSERT_EQ(gpu.alarm(), "");
  for (double fraction : {0.01, 0.1, 0.5, 0.999}) {
    const uint32_t threshold = codec::DetailThreshold(fraction);
    ExpectSubsetIsTheHostSelection(gpu, threshold);
    const SubsetRead on_gpu = ReadSubset(gpu, threshold);
    const SubsetRead on_cpu = ReadSubset(cpu, threshold);
    EXPECT_EQ(on_gpu.written, on_cpu.written) << "fraction " << fraction;
    EXPECT_EQ(Written(on_gpu), Written(on_cpu)) << "fraction " << fraction;
  }
}

// The seed's GPU step is bit-identical to the CPU's (docs/gpu.md), so its subset is too: the
// same floats, every field.
TEST(RankSubsetSeedGpuTest, TheSeedsSubsetHasTheCpusBits) {
  SKIP_WITHOUT_GPU();
  const Scene scene = SceneOf("seed");
  Simulation cpu(scene);
  Simulation gpu(scene, kGpu);
  for (int i = 0; i < 20; ++i) cpu.Step(), gpu.Step();
  const uint32_t threshold = codec::DetailThreshold(0.3);
  const SubsetRead on_gpu = ReadSubset(gpu, threshold);
  const SubsetRead on_cpu = ReadSubset(cpu, threshold);
  EXPECT_EQ(on_gpu.written, on_cpu.written);
  EXPECT_EQ(on_gpu.position, on_cpu.position);
  EXPECT_EQ(on_gpu.velocity, on_cpu.velocity);
  EXPECT_EQ(on_gpu.density, on_cpu.density);
}

// The kept-id table is cached per particle count and threshold: the same threshold after more
// steps reads the new state, a threshold that keeps no particle writes nothing, a return to an
// earlier threshold and a new particle count (a parameter change that resets) rebuild it.
TEST_P(RankSubsetGpuTest, TheCachedTableFollowsThresholdAndCount) {
  SKIP_WITHOUT_GPU();
  const Scene scene = SceneOf(GetParam());
  Simulation gpu(scene, kGpu);
  gpu.Step();
  const uint32_t a = codec::DetailThreshold(0.25), b = codec::DetailThreshold(0.6);
  ExpectSubsetIsTheHostSelection(gpu, a);
  gpu.Step();
  ExpectSubsetIsTheHostSelection(gpu, a);
  ExpectSubsetIsTheHostSelection(gpu, b);
  ExpectSubsetIsTheHostSelection(gpu, a);
  // Threshold 1 keeps the ids of rank 0 only: none among these.
  EXPECT_EQ(ReadSubset(gpu, 1).written, codec::KeptIds(gpu.particle_count(), 1, 1).size());
  // Only the fields asked for are read.
  const SubsetRead all = ReadSubset(gpu, b);
  std::vector<float> velocities(3 * gpu.particle_count(), kUnwritten);
  EXPECT_EQ(gpu.ReadParticlesByIdBelowRank(b, {{}, velocities, {}}), all.written);
  EXPECT_EQ(velocities, all.velocity);
  // A new particle count.
  const size_t before = gpu.particle_count();
  if (GetParam() == "seed") {
    gpu.SetParam("particle_quantity", 12);
  } else {
    gpu.SetParam("particle_spacing", 0.025);
  }
  gpu.Step();
  ASSERT_NE(gpu.particle_count(), before);
  ExpectSubsetIsTheHostSelection(gpu, a);
}

std::string SolverName(const ::testing::TestParamInfo<std::string>& solver) { return solver.param; }

INSTANTIATE_TEST_SUITE_P(Solvers, RankSubsetGpuTest, ::testing::Values("seed", "wcsph", "dfsph"),
                         SolverName);

}  // namespace
}  // namespace dysa
