// Tests of the server's simulation on ranks (server/distributed/src/ranks_backend.cc,
// rank_runner.cc) on one process (SingleProcess): a Simulation stepping on the ranks' backend
// gives the bits of a plain Simulation through frames, parameter changes, checkpoints and
// resets, and what the ranks cannot run is refused by field, nothing applied; the same on GPU
// ranks with the host stand-in for the GPU (host_device_backend.h), dfsph included. On 3
// MPI ranks under dysa-server: mpi_server_test.sh (ctest -L mpi); on 3 GPU ranks:
// mpi_gpu_server_test.sh (ctest -L gpu).
#include "dysa/distributed/ranks_backend.h"

#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "counting_comm.h"
#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "dysa/core/types.h"
#include "host_device_backend.h"
#include "view_reads_testing.h"

#if !defined(DYSA_RANKS_SCENE) || !defined(DYSA_RANKS_SEED_SCENE) || \
    !defined(DYSA_RANKS_DFSPH_SCENE)
#error "tests/CMakeLists.txt defines DYSA_RANKS_SCENE, _SEED_SCENE and _DFSPH_SCENE"
#endif

namespace dysa::distributed {
namespace {

struct OnRanks {
  SingleProcess one;
  std::shared_ptr<RankRunner> runner = std::make_shared<RankRunner>(one);
  Simulation::BackendFactory factory() { return RanksBackendFactory(runner); }
};

// GPU ranks (`mpirun dysa-server --device cuda`) on one process, the host stand-in
// (host_device_backend.h) in the GPU's place: the server's path through the device step
// (distributed_device_step.cc) without a GPU.
struct OnGpuRanks {
  OnGpuRanks() {
    runner->set_device_stand_in([](const std::string& solver) {
      return std::make_unique<dysa::testing::HostDeviceBackend>(solver);
    });
  }
  SingleProcess one;
  std::shared_ptr<RankRunner> runner = std::make_shared<RankRunner>(
      one, BalanceSettings{}, std::vector<Device>{ParseDevice("cuda:0")});
  Simulation::BackendFactory factory() { return RanksBackendFactory(runner); }
};

std::vector<float> PositionsById(const Simulation& sim) {
  std::vector<float> p(3 * sim.particle_count());
  sim.ReadParticlesById({p, {}, {}});
  return p;
}

void ExpectSameState(const Simulation& ranks, const Simulation& plain, const char* where) {
  ASSERT_EQ(ranks.step(), plain.step()) << where;
  ASSERT_EQ(ranks.frame(), plain.frame()) << where;
  ASSERT_EQ(ranks.time(), plain.time()) << where;
  ASSERT_EQ(StateHash(ranks.state()), StateHash(plain.state())) << where;
  ASSERT_EQ(PositionsById(ranks), PositionsById(plain)) << where;
}

template <class Ranks = OnRanks>
void ExpectSameBits(const Scene& scene, const char* described = "cpu, 1 rank") {
  Ranks ranks;
  Simulation spread(scene, Device{}, ranks.factory());
  Simulation plain(scene);
  EXPECT_EQ(spread.DeviceDescription(), described);
  ExpectSameState(spread, plain, "start");
  for (int f = 0; f < 3; ++f) {
    spread.StepFrame();
    plain.StepFrame();
  }
  ExpectSameState(spread, plain, "3 frames");
  // A frame in pieces, a checkpoint taken inside it and restored.
  const Checkpoint a = spread.SaveCheckpoint();
  const Checkpoint b = plain.SaveCheckpoint();
  EXPECT_EQ(a.id, b.id);
  EXPECT_EQ(a.position, b.position);
  EXPECT_EQ(a.velocity, b.velocity);
  ASSERT_EQ(a.solver_arrays.size(), b.solver_arrays.size());
  for (size_t k = 0; k < a.solver_arrays.size(); ++k) {
    EXPECT_EQ(a.solver_arrays[k].values, b.solver_arrays[k].values);
  }
  // One step of the next frame (the seed's has 3, wcsph's more).
  EXPECT_FALSE(spread.StepFrame([] { return true; }));
  spread.RestoreCheckpoint(a);
  Params p = plain.params();
  p.iterations_per_frame = 4;    // the seed's frame
  p.kinematic_viscosity = 2e-6;  // wcsph's
  ASSERT_FALSE(spread.SetParams(p));
  ASSERT_FALSE(plain.SetParams(p));
  for (int f = 0; f < 2; ++f) {
    spread.StepFrame();
    plain.StepFrame();
  }
  ExpectSameState(spread, plain, "restored, parameters changed, 2 frames");
  spread.Reset();
  plain.Reset();
  spread.StepFrame();
  plain.StepFrame();
  ExpectSameState(spread, plain, "reset, 1 frame");
}

TEST(RanksBackendTest, SteppingOnTheRanksGivesTheBitsOfOneProcess) {
  ExpectSameBits(LoadScene(DYSA_RANKS_SCENE));
}

TEST(RanksBackendTest, ABudgetedReadTakesTheSubsetFromTheRanks) {
  // A level of detail's subset (a budgeted stream's frame) read straight after a step, while
  // the particles live on the ranks: the ranks' gather of the subset writes what one process
  // writes, and nothing else.
  const Scene scene = LoadScene(DYSA_RANKS_SCENE);
  OnRanks ranks;
  Simulation spread(scene, Device{}, ranks.factory());
  Simulation plain(scene);
  spread.StepFrame();
  plain.StepFrame();
  const size_t n = plain.particle_count();
  constexpr uint32_t kThreshold = 1u << 29;  // an eighth of the ranks
  const float kUnwritten = -7;
  std::vector<float> p(3 * n, kUnwritten), v(3 * n, kUnwritten), d(n, kUnwritten);
  std::vector<float> q(3 * n, kUnwritten), w(3 * n, kUnwritten), e(n, kUnwritten);
  const size_t got = spread.ReadParticlesByIdBelowRank(kThreshold, {p, v, d});
  const size_t want = plain.ReadParticlesByIdBelowRank(kThreshold, {q, w, e});
  EXPECT_EQ(got, want);
  EXPECT_GT(got, n / 16);
  EXPECT_LT(got, n / 4);
  EXPECT_EQ(p, q);
  EXPECT_EQ(v, w);
  EXPECT_EQ(d, e);
}

TEST(RanksBackendTest, AViewStreamsReadsComeFromTheRanks) {
  // A view stream's reads straight after a step, while the particles live on the ranks: by
  // ids, the position bounds and the view's subset, each taken where the particles live, write
  // what one process writes, and move only what they send (mpi_view_reads_test: each of 2 and
  // 3 ranks sends its share).
  const Scene scene = LoadScene(DYSA_RANKS_SCENE);
  SingleProcess one;
  CountingComm counting(one);
  Simulation spread(scene, Device{}, RanksBackendFactory(std::make_shared<RankRunner>(counting)));
  Simulation plain(scene);
  spread.StepFrame();
  plain.StepFrame();
  const size_t n = plain.particle_count();
  std::vector<uint32_t> ids;
  for (uint32_t k = 0; k < n; k += 10) ids.push_back(k);
  std::vector<float> p(3 * n);
  counting.Clear();
  spread.ReadParticlesByIds(ids, {p, {}, {}});
  EXPECT_EQ(counting.gathered, std::vector<size_t>{ids.size() * 16});  // id and position
  counting.Clear();
  spread.ReadPositionBounds();
  EXPECT_EQ(counting.gathered, std::vector<size_t>{60});  // per axis 2 extremes, a zero's key
  EXPECT_EQ(counting.max_values, 0u);
  counting.Clear();
  std::vector<uint32_t> chosen;
  auto calls = std::make_shared<int>(0);
  spread.ReadViewSubset(TestViewRequest({0, 0, 0}, {0.4, 0.2, 0.04}, 1, calls), 100, chosen,
                        {p, {}, {}});
  EXPECT_EQ(chosen.size(), 100u);
  ASSERT_EQ(counting.gathered.size(), 3u);  // cells' counts, (key, id) pairs, the particles
  EXPECT_EQ(counting.gathered[1], 100u * 8);
  EXPECT_EQ(counting.gathered[2], 100u * 16);
  ExpectSameViewReads(spread, plain);
  spread.StepFrame();
  plain.StepFrame();
  ExpectSameViewReads(spread, plain);
}

TEST(RanksBackendTest, TheSeedToo) { ExpectSameBits(LoadScene(DYSA_RANKS_SEED_SCENE)); }

// dfsph's checkpoint holds its warm start (density_stiffness, divergence_stiffness), which the
// restore sends back to the ranks.
TEST(RanksBackendTest, DfsphToo) { ExpectSameBits(LoadScene(DYSA_RANKS_DFSPH_SCENE)); }

TEST(RanksBackendTest, APhysicalSolversWarningIsOneProcesss) {
  Scene scene = LoadScene(DYSA_RANKS_SCENE);
  scene.params.speed_of_sound = 1;  // the fluid is thrown at 1.5 m/s
  OnRanks ranks;
  Simulation spread(scene, Device{}, ranks.factory());
  Simulation plain(scene);
  spread.StepFrame();
  plain.StepFrame();
  EXPECT_NE(plain.warning(), "");
  EXPECT_EQ(spread.warning(), plain.warning());
}

TEST(RanksBackendTest, WhatTheRanksCannotRunIsRefusedByField) {
  OnRanks ranks;
  Scene scene = LoadScene(DYSA_RANKS_SCENE);
  Scene unspread = scene;
  unspread.solver = "mps";  // not a solver that runs across processes
  try {
    CheckRunsOnRanks(unspread, unspread.params, 1);
    FAIL() << "mps ran on the ranks";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.field(), "solver");
  }
  // The tank is 40 cell layers long: each of 41 ranks could not own one.
  try {
    CheckRunsOnRanks(scene, scene.params, 41);
    FAIL() << "41 ranks accepted for 40 layers";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.field(), "processes");
  }
  Scene in_code = scene;
  in_code.source_json.clear();
  try {
    Simulation refused(in_code, Device{}, ranks.factory());
    FAIL() << "a scene without JSON text ran on the ranks";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.field(), "scene");
  }
  Simulation sim(scene, Device{}, ranks.factory());
  Simulation plain(scene);
  sim.StepFrame();
  plain.StepFrame();
  ExpectSameState(sim, plain, "after the refusal");
  // The predictor-corrector runs on the ranks (time_integration 1), to the same bits.
  Params p = sim.params();
  p.time_integration = 1;
  sim.SetParams(p);
  plain.SetParams(p);
  EXPECT_EQ(sim.params().time_integration, 1);
  sim.StepFrame();
  plain.StepFrame();
  ExpectSameState(sim, plain, "the predictor-corrector");
}

// The server's GPU ranks: through frames, a checkpoint inside a frame restored, a parameter
// change and a reset, one process's bits (wcsph, both time integrations, and the seed).
TEST(RanksBackendTest, OnGpuRanksTheServersPathGivesTheBitsOfOneProcess) {
  ExpectSameBits<OnGpuRanks>(LoadScene(DYSA_RANKS_SCENE), "cuda:0, 1 rank");
  ExpectSameBits<OnGpuRanks>(LoadScene(DYSA_RANKS_SEED_SCENE), "cuda:0, 1 rank");
  OnGpuRanks ranks;
  const Scene scene = LoadScene(DYSA_RANKS_SCENE);
  Simulation sim(scene, Device{}, ranks.factory());
  Simulation plain(scene);
  Params p = sim.params();
  p.time_integration = 1;  // the predictor-corrector, on the device's two sorts
  ASSERT_FALSE(sim.SetParams(p));
  ASSERT_FALSE(plain.SetParams(p));
  for (int f = 0; f < 2; ++f) {
    sim.StepFrame();
    plain.StepFrame();
  }
  ExpectSameState(sim, plain, "the predictor-corrector on GPU ranks");
}

// dfsph on GPU ranks (its ghosts refreshed through the device's hook, its mean errors over the
// owned particles combined over the ranks): its scene, and the dam break loaded with `solver`
// dfsph (`dysa load SCENE --solver dfsph`) onto ranks stepping wcsph, give one process's bits.
TEST(RanksBackendTest, OnGpuRanksDfsphGivesTheBitsOfOneProcess) {
  ExpectSameBits<OnGpuRanks>(LoadScene(DYSA_RANKS_DFSPH_SCENE), "cuda:0, 1 rank");
  OnGpuRanks ranks;
  const Scene scene = LoadScene(DYSA_RANKS_SCENE);
  Simulation wcsph(scene, Device{}, ranks.factory());
  wcsph.StepFrame();
  Scene swapped = scene;
  swapped.solver = "dfsph";
  EXPECT_NO_THROW(
      DistributedSimulation::CheckSupported(swapped, swapped.params, ParseDevice("cuda:0")));
  Simulation sim(swapped, Device{}, ranks.factory());
  Simulation plain(swapped);
  ASSERT_NE(ranks.runner->simulation(), nullptr);
  EXPECT_EQ(ranks.runner->simulation()->scene().solver, "dfsph");
  for (int f = 0; f < 3; ++f) {
    sim.StepFrame();
    plain.StepFrame();
  }
  ExpectSameState(sim, plain, "the dam break with dfsph on GPU ranks");
}

}  // namespace
}  // namespace dysa::distributed
