// Tests of a view stream's reads between two selections on the GPU
// (server/core/src/cuda/view_reads.cu): Simulation::ReadParticlesByIds gathers the listed
// particles on the device and ReadPositionBounds reduces the positions there, for the three
// solvers' CUDA backends. Both have the bits of the host's path on the same state (a CPU
// simulation restored from the GPU's checkpoint, and the GPU simulation's own host copy), for
// ids in increasing, random and reversed order, one id, none, and fields alone; the bounds of a
// seed fluid resting on a floor at 0 (a zero extreme) and of a state holding NaNs.
// ctest label `gpu`: every test skips, printing why, where no CUDA GPU can run (a build without
// CUDA, no driver, no GPU).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "support/gpu_test.h"

namespace dysa {
namespace {

using dysa::testing::kGpu;

// A NaN with a payload no read produces: an entry left as it was keeps these bits.
float NotWritten() {
  const uint32_t bits = 0x7fc0beefu;
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

uint32_t Bits(float f) {
  uint32_t u;
  std::memcpy(&u, &f, sizeof u);
  return u;
}

// Whether a and b hold the same bits (NaNs and zeros' signs included), naming the first entry
// that differs.
::testing::AssertionResult SameBits(const std::vector<float>& a, const std::vector<float>& b) {
  if (a.size() != b.size()) {
    return ::testing::AssertionFailure() << a.size() << " floats vs " << b.size();
  }
  for (size_t e = 0; e < a.size(); ++e) {
    if (Bits(a[e]) != Bits(b[e])) {
      return ::testing::AssertionFailure()
             << "entry " << e << ": " << a[e] << " (0x" << std::hex << Bits(a[e]) << ") vs " << b[e]
             << " (0x" << Bits(b[e]) << ")";
    }
  }
  return ::testing::AssertionSuccess();
}

::testing::AssertionResult SameBounds(const Simulation::PositionBounds& a,
                                      const Simulation::PositionBounds& b) {
  for (int axis = 0; axis < 3; ++axis) {
    if (Bits(a.lo[axis]) != Bits(b.lo[axis]) || Bits(a.hi[axis]) != Bits(b.hi[axis])) {
      return ::testing::AssertionFailure()
             << "axis " << axis << ": [" << a.lo[axis] << ", " << a.hi[axis] << "] (0x" << std::hex
             << Bits(a.lo[axis]) << ", 0x" << Bits(a.hi[axis]) << ") vs [" << b.lo[axis] << ", "
             << b.hi[axis] << "] (0x" << Bits(b.lo[axis]) << ", 0x" << Bits(b.hi[axis]) << ")";
    }
  }
  return ::testing::AssertionSuccess();
}

// The seed's fluid falling onto a floor at y = 0: without a bounce (no collision damping) the
// wall clamps the lowest particles to y = 0 step after step, so the smallest y is exactly zero.
// 16^3 particles.
Scene FloorScene() {
  return ParseScene(R"({
    "domain": {"min": [0, 0, 0], "max": [10, 6, 10]},
    "fluid_blocks": [{"center": [5, 2.6, 5], "seed": 1}],
    "solver": "seed",
    "params": {"gravity": -10, "collision_damping": 0, "particle_quantity": 16,
               "spawn_size": 5, "spawn_jitter": 0.035}
  })");
}

Scene SceneOf(const std::string& solver) {
  if (solver == "seed") return FloorScene();
  Scene scene = dysa::testing::DamScene(solver);
  SetParam(scene.params, "particle_spacing", 0.01);  // 20 x 30 x 8 particles
  return scene;
}

// Steps until the storage is no longer in id order (and, for the seed, the fluid lies on the
// floor).
void Advance(Simulation& sim, const std::string& solver) {
  if (solver == "seed") {
    for (int f = 0; f < 30; ++f) sim.StepFrame();
  } else {
    for (int i = 0; i < 5; ++i) sim.Step();
  }
}

// Lists of ids: none, the last, the first, every 7th increasing, a random half in random order,
// every id in decreasing order.
std::vector<std::vector<uint32_t>> IdListsOf(uint32_t n) {
  std::vector<std::vector<uint32_t>> lists = {{}, {n - 1}, {0}};
  std::vector<uint32_t>& sparse = lists.emplace_back();
  for (uint32_t k = 3; k < n; k += 7) sparse.push_back(k);
  std::vector<uint32_t> all(n);
  std::iota(all.begin(), all.end(), 0u);
  std::mt19937 random(7);
  std::shuffle(all.begin(), all.end(), random);
  lists.emplace_back(all.begin(), all.begin() + n / 2);
  std::vector<uint32_t>& reversed = lists.emplace_back(n);
  for (uint32_t k = 0; k < n; ++k) reversed[k] = n - 1 - k;
  return lists;
}

// The fields a read asks for.
struct Fields {
  bool position, velocity, density;
};
constexpr Fields kFieldChoices[] = {{true, true, true}, {true, false, false}, {false, true, true}};

// What a read by ids writes into arrays of NotWritten(): the full read's entries of `ids`.
struct ByIds {
  std::vector<float> position, velocity, density;
};
ByIds Expected(const ByIds& full, const std::vector<uint32_t>& ids, Fields f) {
  const size_t n = full.density.size();
  ByIds e{std::vector<float>(f.position ? 3 * n : 0, NotWritten()),
          std::vector<float>(f.velocity ? 3 * n : 0, NotWritten()),
          std::vector<float>(f.density ? n : 0, NotWritten())};
  for (const uint32_t k : ids) {
    for (int a = 0; a < 3; ++a) {
      if (f.position) e.position[3 * k + a] = full.position[3 * k + a];
      if (f.velocity) e.velocity[3 * k + a] = full.velocity[3 * k + a];
    }
    if (f.density) e.density[k] = full.density[k];
  }
  return e;
}
ByIds Read(const Simulation& sim, const std::vector<uint32_t>& ids, Fields f) {
  const size_t n = sim.particle_count();
  ByIds r{std::vector<float>(f.position ? 3 * n : 0, NotWritten()),
          std::vector<float>(f.velocity ? 3 * n : 0, NotWritten()),
          std::vector<float>(f.density ? n : 0, NotWritten())};
  EXPECT_EQ(sim.ReadParticlesByIds(ids, {r.position, r.velocity, r.density}), ids.size());
  return r;
}
ByIds FullRead(const Simulation& sim) {
  const size_t n = sim.particle_count();
  ByIds full{std::vector<float>(3 * n), std::vector<float>(3 * n), std::vector<float>(n)};
  sim.ReadParticlesById({full.position, full.velocity, full.density});
  return full;
}

// A sequential scan of the storage, as the host defines the bounds: std::min and std::max from
// +inf and -inf.
Simulation::PositionBounds SequentialBounds(const std::vector<Vec3>& position) {
  Simulation::PositionBounds b;
  for (int a = 0; a < 3; ++a) {
    float lo = std::numeric_limits<float>::infinity(), hi = -lo;
    for (const Vec3& x : position) lo = std::min(lo, float(x[a])), hi = std::max(hi, float(x[a]));
    b.lo[a] = lo;
    b.hi[a] = hi;
  }
  return b;
}

class ViewReadsGpuTest : public ::testing::TestWithParam<std::string> {};

// After steps, every list and choice of fields read on the device has the bits of the device's
// full read, and of the host's read of the same state (a CPU simulation restored from the GPU's
// checkpoint: positions and velocities; the GPU simulation's host copy: every field).
TEST_P(ViewReadsGpuTest, AGatherByIdHasTheHostsBits) {
  SKIP_WITHOUT_GPU();
  Simulation gpu(SceneOf(GetParam()), kGpu);
  Advance(gpu, GetParam());
  ASSERT_EQ(gpu.alarm(), "");
  const auto n = uint32_t(gpu.particle_count());
  ASSERT_GT(n, 1000u);
  const ByIds full = FullRead(gpu);
  const uint64_t bytes = gpu.DeviceBytes();
  const std::vector<std::vector<uint32_t>> lists = IdListsOf(n);
  std::vector<ByIds> on_device;
  on_device.reserve(lists.size() * std::size(kFieldChoices));
  for (const std::vector<uint32_t>& ids : lists) {
    for (const Fields f : kFieldChoices) {
      const ByIds e = Expected(full, ids, f);
      const ByIds& r = on_device.emplace_back(Read(gpu, ids, f));
      ASSERT_TRUE(SameBits(r.position, e.position)) << ids.size() << " ids";
      ASSERT_TRUE(SameBits(r.velocity, e.velocity)) << ids.size() << " ids";
      ASSERT_TRUE(SameBits(r.density, e.density)) << ids.size() << " ids";
    }
  }
  // The device's buffers: the read ran there.
  EXPECT_GT(gpu.DeviceBytes(), bytes);
  // An id past the particles: nothing read, nothing written.
  std::vector<float> untouched(3 * size_t(n), NotWritten());
  const std::vector<uint32_t> past = {1, n};
  EXPECT_THROW(gpu.ReadParticlesByIds(past, {untouched, {}, {}}), std::out_of_range);
  EXPECT_TRUE(SameBits(untouched, std::vector<float>(3 * size_t(n), NotWritten())));

  // The host's reads of the same state.
  Simulation cpu(SceneOf(GetParam()));
  cpu.RestoreCheckpoint(gpu.SaveCheckpoint());
  size_t r = 0;
  for (const std::vector<uint32_t>& ids : lists) {
    for (const Fields f : kFieldChoices) {
      const ByIds& d = on_device[r++];
      const ByIds c = Read(cpu, ids, {f.position, f.velocity, false});
      ASSERT_TRUE(SameBits(d.position, c.position)) << ids.size() << " ids, cpu";
      ASSERT_TRUE(SameBits(d.velocity, c.velocity)) << ids.size() << " ids, cpu";
    }
  }
  gpu.state();  // from now on the GPU simulation reads its host copy
  r = 0;
  for (const std::vector<uint32_t>& ids : lists) {
    for (const Fields f : kFieldChoices) {
      const ByIds& d = on_device[r++];
      const ByIds h = Read(gpu, ids, f);
      ASSERT_TRUE(SameBits(d.position, h.position)) << ids.size() << " ids, host copy";
      ASSERT_TRUE(SameBits(d.velocity, h.velocity)) << ids.size() << " ids, host copy";
      ASSERT_TRUE(SameBits(d.density, h.density)) << ids.size() << " ids, host copy";
    }
  }
}

// The buffers follow more steps and a new particle count (a parameter change that resets).
TEST_P(ViewReadsGpuTest, TheGatherFollowsStepsAndANewCount) {
  SKIP_WITHOUT_GPU();
  Simulation gpu(SceneOf(GetParam()), kGpu);
  gpu.Step();
  for (int round = 0; round < 3; ++round) {
    if (round == 1) {
      for (int i = 0; i < 4; ++i) gpu.Step();
    } else if (round == 2) {
      const size_t n = gpu.particle_count();
      if (GetParam() == "seed") {
        gpu.SetParam("particle_quantity", 12);
      } else {
        gpu.SetParam("particle_spacing", 0.02);
      }
      gpu.Step();
      ASSERT_NE(gpu.particle_count(), n);
    }
    const ByIds full = FullRead(gpu);
    for (const std::vector<uint32_t>& ids : IdListsOf(uint32_t(gpu.particle_count()))) {
      const ByIds e = Expected(full, ids, kFieldChoices[0]);
      const ByIds r = Read(gpu, ids, kFieldChoices[0]);
      ASSERT_TRUE(SameBits(r.position, e.position)) << "round " << round;
      ASSERT_TRUE(SameBits(r.velocity, e.velocity)) << "round " << round;
      ASSERT_TRUE(SameBits(r.density, e.density)) << "round " << round;
    }
  }
}

// The bounds reduced on the device have the bits of a sequential scan of the storage, of a CPU
// simulation restored from the GPU's checkpoint and of the GPU simulation's host copy; the
// seed's fluid lies on the floor, so its smallest y is a zero.
TEST_P(ViewReadsGpuTest, TheBoundsHaveTheHostsBits) {
  SKIP_WITHOUT_GPU();
  Simulation gpu(SceneOf(GetParam()), kGpu);
  Advance(gpu, GetParam());
  ASSERT_EQ(gpu.alarm(), "");
  const uint64_t bytes = gpu.DeviceBytes();
  const Simulation::PositionBounds b = gpu.ReadPositionBounds();
  EXPECT_GT(gpu.DeviceBytes(), bytes);  // the device's buffers: the reduction ran there
  const Checkpoint checkpoint = gpu.SaveCheckpoint();
  EXPECT_TRUE(SameBounds(b, SequentialBounds(checkpoint.position)));
  for (int a = 0; a < 3; ++a) EXPECT_LT(b.lo[a], b.hi[a]) << a;
  if (GetParam() == "seed") {
    EXPECT_EQ(Bits(b.lo[1]), Bits(0.0f));
  }
  Simulation cpu(SceneOf(GetParam()));
  cpu.RestoreCheckpoint(checkpoint);
  EXPECT_TRUE(SameBounds(b, cpu.ReadPositionBounds()));
  gpu.state();  // from now on the GPU simulation reads its host copy
  EXPECT_TRUE(SameBounds(b, gpu.ReadPositionBounds()));
}

// A state with NaNs (a NaN velocity, stepped: the alarm stops the run, the state stays
// readable): the bounds skip them as the host does, and a gather by id copies them bit for bit.
// The seed's, whose pipeline is known to step through a NaN (seed_pipeline_test).
TEST(ViewReadsGpuSeedTest, NaNsAreSkippedByTheBoundsAndCopiedByTheGather) {
  SKIP_WITHOUT_GPU();
  Simulation gpu(FloorScene(), kGpu);
  gpu.StepFrame();
  Checkpoint broken = gpu.SaveCheckpoint();
  broken.velocity[5].x() = std::numeric_limits<Real>::quiet_NaN();
  gpu.RestoreCheckpoint(broken);
  gpu.Step();
  ASSERT_NE(gpu.alarm(), "");
  const ByIds full = FullRead(gpu);
  std::vector<uint32_t> nan_ids;
  for (uint32_t k = 0; k < gpu.particle_count(); ++k) {
    if (std::isnan(full.position[3 * size_t(k)])) nan_ids.push_back(k);
  }
  ASSERT_FALSE(nan_ids.empty()) << "no NaN position after the step";
  ASSERT_LT(nan_ids.size(), gpu.particle_count());
  // On the device.
  const Simulation::PositionBounds b = gpu.ReadPositionBounds();
  std::vector<uint32_t> ids = nan_ids;
  if (ids.front() != 0) ids.insert(ids.begin(), 0);
  std::reverse(ids.begin(), ids.end());
  const ByIds r = Read(gpu, ids, kFieldChoices[0]);
  const ByIds e = Expected(full, ids, kFieldChoices[0]);
  EXPECT_TRUE(SameBits(r.position, e.position));
  EXPECT_TRUE(SameBits(r.velocity, e.velocity));
  EXPECT_TRUE(SameBits(r.density, e.density));
  for (int a = 0; a < 3; ++a) {
    EXPECT_FALSE(std::isnan(b.lo[a]) || std::isnan(b.hi[a])) << a;
    EXPECT_LE(b.lo[a], b.hi[a]) << a;
  }
  EXPECT_TRUE(SameBounds(b, SequentialBounds(gpu.SaveCheckpoint().position)));
  // The host copy.
  gpu.state();
  EXPECT_TRUE(SameBounds(b, gpu.ReadPositionBounds()));
  const ByIds h = Read(gpu, ids, kFieldChoices[0]);
  EXPECT_TRUE(SameBits(r.position, h.position));
  EXPECT_TRUE(SameBits(r.velocity, h.velocity));
  EXPECT_TRUE(SameBits(r.density, h.density));
}

std::string SolverName(const ::testing::TestParamInfo<std::string>& solver) { return solver.param; }

INSTANTIATE_TEST_SUITE_P(Solvers, ViewReadsGpuTest, ::testing::Values("seed", "wcsph", "dfsph"),
                         SolverName);

}  // namespace
}  // namespace dysa
