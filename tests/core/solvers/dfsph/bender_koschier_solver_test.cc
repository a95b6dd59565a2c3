// Tests of the dfsph solver (server/core/src/solvers/dfsph): its pass list, determinism for
// any thread count (iteration counts included), its warm start, bit-identical checkpoints, solves
// that reach their tolerances, and no leakage through walls and obstacles.
#include "solvers/dfsph/bender_koschier_solver.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <tuple>

#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "sph_loops.h"
#include "support/gpu_test.h"
#include "support/with_threads.h"

namespace dysa {
namespace {

using dfsph::BenderKoschierData;
using dfsph::NeighborPairs;
using dysa::testing::WithThreads;

// dfsph's own data (pair lists, warm start) of a CPU simulation.
const BenderKoschierData& DataOf(const Simulation& sim) {
  return dynamic_cast<const dfsph::BenderKoschierSolver&>(*sim.solver()).data();
}

// The small dam break of becker_teschner_solver_test: 600 particles past a sphere and a box.
Scene DamScene() {
  Scene scene = ParseScene(R"({
    "domain": {"min": [0, 0, 0], "max": [0.6, 0.4, 0.08]},
    "fluid_blocks": [{"center": [0.1, 0.15, 0.04], "size": [0.2, 0.3, 0.08]}],
    "solver": "dfsph",
    "params": {"gravity": -9.81, "particle_spacing": 0.02, "kinematic_viscosity": 1e-5,
               "cfl_factor": 0.4, "max_time_step": 0.002}
  })");
  scene.spheres.push_back({Vec3d(0.33, 0.0, 0.04), 0.07, {}});
  scene.boxes.push_back({Aabb{Vec3d(0.48, 0, -0.1), Vec3d(0.52, 0.08, 0.2)}, {}});
  return scene;
}

TEST(DfsphPassListTest, RunsBothSolvesAroundTheStep) {
  const Simulation sim(DamScene());
  const std::vector<std::string> expected = {
      "neighbour_grid", "density",   "boundary_pressure", "divergence_solve", "external_forces",
      "viscosity",      "time_step", "predict_velocity",  "density_solve",    "integrate"};
  EXPECT_EQ(sim.PassNames(), expected);
  EXPECT_DOUBLE_EQ(sim.model().particle_mass, 1000 * 0.02 * 0.02 * 0.02);
}

// The warm start carries each solve's pressure impulse into the next step: a column at rest
// then needs fewer iterations to hold its weight, to the same tolerance (printed: 3,016
// without it, 1,538 with warm_start 0.5). The block settles for 0.2 s (gravity ramped in),
// then 0.2 s are counted.
// The density pass lists each particle's pairs for the solves: every fluid particle within the
// kernel's support at a distance > 0 (brute force over the grid's positions, which the step's
// passes read), once, with its kernel gradient. A pair within rounding of the support's edge
// may fall either way.
TEST(DfsphPairListTest, ListsEveryPairWithinTheSupportOnce) {
  Simulation sim(DamScene());
  for (int i = 0; i < 30; ++i) sim.Step();
  const State& state = sim.state();
  const BenderKoschierData& data = DataOf(sim);
  const NeighborPairs& pairs = data.fluid_pairs;
  const size_t n = state.particles.size();
  ASSERT_EQ(pairs.begin.size(), n + 1);
  ASSERT_EQ(pairs.other.size(), pairs.begin[n]);
  ASSERT_EQ(pairs.grad_w.size(), pairs.begin[n]);
  const PhysicalKernel<Real> kernel = sim.model().Kernel();
  const Real support = kernel.support;
  // The gradient's scale: its largest magnitude, at r = 2/3 of the support.
  const Real scale = GradW(Vec3(support * 2 / 3, 0, 0), support * 2 / 3, kernel).norm();
  const auto& xs = state.grid.xs();
  const auto& ys = state.grid.ys();
  const auto& zs = state.grid.zs();
  size_t found = 0;
  for (size_t i = 0; i < n; ++i) {
    std::map<uint32_t, Vec3> listed;
    for (size_t k = pairs.begin[i]; k < pairs.begin[i + 1]; ++k) {
      EXPECT_TRUE(listed.emplace(pairs.other[k], pairs.grad_w[k]).second) << "pair listed twice";
    }
    for (uint32_t j = 0; j < n; ++j) {
      const Vec3 xij(xs[i] - xs[j], ys[i] - ys[j], zs[i] - zs[j]);
      const Real r = xij.norm();
      const bool edge = std::abs(r - support) < 1e-5f * support;
      const auto it = listed.find(j);
      if (it == listed.end()) {
        EXPECT_TRUE(!(r > 0 && r < support) || edge)
            << "particle " << i << " misses neighbour " << j << " at " << r / support;
        continue;
      }
      ++found;
      EXPECT_TRUE((r > 0 && r < support) || edge) << i << " lists " << j << " at " << r;
      EXPECT_LE((it->second - GradW(xij, r, kernel)).norm(), 1e-5f * scale) << i << ", " << j;
    }
  }
  EXPECT_EQ(found, pairs.other.size());
  EXPECT_GT(found, 20 * n);  // a 3D block: about 30 neighbours each
  EXPECT_GT(data.boundary_pairs.other.size(), 0u);
}

// The GPU's pair lists keep only the other particle and recompute grad W where the solves read
// it (PairGradW in cuda/dfsph_kernels.cuh), from the positions, which stay put from the density
// pass to the integration; the GPU's dfsph is bit-identical to the CPU only if that gives the
// density pass's bits. This is PairGradW's arithmetic in host code: x_ij = (x_i + shift) - x_j
// with ForEachNeighborRun's shift across a periodic axis's seam told by x_i - x_j beyond +-L/2,
// r = sqrt(|x_ij|^2), GradW.
Vec3 RecomputedGradW(const NeighborGrid& grid, const Vec3& xi, const Vec3& xj,
                     const PhysicalKernel<Real>& kernel) {
  Vec3 q;
  for (int a = 0; a < 3; ++a) {
    Real shift = 0;
    if (grid.periodic()[a]) {
      const Real d = xi[a] - xj[a], period = grid.periods()[a];
      if (d < -0.5f * period) shift = period;
      if (d > 0.5f * period) shift = -period;
    }
    q[a] = xi[a] + shift;
  }
  const Vec3 xij(q.x() - xj.x(), q.y() - xj.y(), q.z() - xj.z());
  return GradW(xij, std::sqrt(xij.squaredNorm()), kernel);
}

// Every listed gradient, fluid and wall, is the recomputation's to the bit: across walls and
// obstacles, the Wendland kernel, and the periodic channel (3 cells along z, the tightest).
TEST(DfsphPairListTest, EveryGradientIsRecomputedBitForBitFromThePositions) {
  for (const Scene& scene : {DamScene(), dysa::testing::WendlandDamScene("dfsph"),
                             dysa::testing::PeriodicScene("dfsph")}) {
    Simulation sim(scene);
    for (int i = 0; i < 40; ++i) sim.Step();
    const State& state = sim.state();
    const BenderKoschierData& data = DataOf(sim);
    const PhysicalKernel<Real> kernel = sim.model().Kernel();
    const NeighborGrid& walls = data.boundary->grid();
    size_t across_seam = 0, mismatches = 0;
    const auto check = [&](const NeighborGrid& grid, const NeighborPairs& pairs, size_t i) {
      // The positions the density pass read: the grid's copy (the step has moved the particles).
      const Vec3 xi(state.grid.xs()[i], state.grid.ys()[i], state.grid.zs()[i]);
      for (size_t k = pairs.begin[i]; k < pairs.begin[i + 1]; ++k) {
        const uint32_t j = pairs.other[k];
        const Vec3 xj(grid.xs()[j], grid.ys()[j], grid.zs()[j]);
        const Vec3 g = RecomputedGradW(grid, xi, xj, kernel);
        if ((xi - xj).cwiseAbs().maxCoeff() > 2 * kernel.support) ++across_seam;
        if (std::memcmp(g.data(), pairs.grad_w[k].data(), sizeof(Vec3)) != 0 && ++mismatches < 5) {
          ADD_FAILURE() << "pair (" << i << ", " << j << "): " << g.transpose() << " listed as "
                        << pairs.grad_w[k].transpose();
        }
      }
    };
    for (size_t i = 0; i < state.particles.size(); ++i) {
      check(state.grid, data.fluid_pairs, i);
      check(walls, data.boundary_pairs, i);
    }
    EXPECT_EQ(mismatches, 0u);
    EXPECT_GT(data.boundary_pairs.other.size(), 0u);
    if (state.grid.periodic()[0]) {
      EXPECT_GT(across_seam, 0u);  // the seams were crossed
    }
  }
}

TEST(DfsphPairListTest, TheLayoutDoesNotDependOnTheThreadCount) {
  auto run = [](int threads) {
    return WithThreads(threads, [] {
      Simulation sim(DamScene());
      for (int i = 0; i < 20; ++i) sim.Step();
      const BenderKoschierData& s = DataOf(sim);
      return std::make_tuple(s.fluid_pairs.begin, s.fluid_pairs.other, s.boundary_pairs.begin,
                             s.boundary_pairs.other);
    });
  };
  EXPECT_EQ(run(1), run(3));
}

// A water column 0.3 m deep in a 0.2 m wide tank, gravity ramped in over 0.1 s.
Scene RestingColumnScene() {
  return ParseScene(R"({
    "domain": {"min": [0, 0, 0], "max": [0.2, 0.4, 0.08]},
    "fluid_blocks": [{"center": [0.1, 0.15, 0.04], "size": [0.2, 0.3, 0.08]}],
    "solver": "dfsph",
    "params": {"gravity": -9.81, "gravity_ramp_time": 0.1, "particle_spacing": 0.02,
               "kinematic_viscosity": 1e-3, "max_time_step": 0.004}
  })");
}

TEST(DfsphWarmStartTest, ARestingColumnNeedsFewerIterations) {
  auto iterations = [](double warm_start) {
    Scene scene = RestingColumnScene();
    scene.params.warm_start = warm_start;
    Simulation sim(scene);
    while (sim.state().time < 0.2) sim.Step(0.2);
    uint64_t total = 0;
    while (sim.state().time < 0.4) {
      sim.Step(0.4);
      total += uint64_t(sim.solver_stats().density_iterations +
                        sim.solver_stats().divergence_iterations);
    }
    EXPECT_EQ(sim.solver_stats().capped_solves, 0u) << "warm_start " << warm_start;
    EXPECT_LT(sim.solver_stats().density_error, 1e-4) << "warm_start " << warm_start;
    return total;
  };
  const uint64_t cold = iterations(0);
  const uint64_t warm = iterations(0.5);
  std::printf("iterations over 0.2 s: %llu without the warm start, %llu with 0.5\n",
              (unsigned long long)cold, (unsigned long long)warm);
  EXPECT_LT(double(warm), 0.8 * double(cold));
}

// Signed corrections take back what a warm start over-applies. A column at rest, started from all
// of the previous step's pressure (warm_start 1): one-signed solves keep the excess and the
// column's pressure drifts off rho0 g (H - y) (printed: the worst layer 5.5% of rho0 g H off);
// signed ones hold it as close as the one-signed default (warm_start 0.2; 1.5%, most of it the
// layers' binning) with fewer iterations, and no particle's pressure below zero (the solves'
// totals stay >= 0).
TEST(DfsphSignedCorrectionsTest, TakeBackWhatTheWarmStartOverApplies) {
  struct Outcome {
    double worst_error;  // the worst layer's |<p> - rho0 g (H - y)| / (rho0 g H)
    double lowest_pressure;
    uint64_t iterations;  // both solves', over the counted 0.3 s
  };
  auto run = [](double warm_start, int signed_corrections) {
    Scene scene = RestingColumnScene();
    scene.params.warm_start = warm_start;
    scene.params.signed_corrections = signed_corrections;
    Simulation sim(scene);
    while (sim.state().time < 0.3) sim.Step(0.3);
    // Each 0.02 m layer's pressure, averaged over its particles and the counted steps, below the
    // top two layers (their kernel deficit).
    constexpr int kLayers = 13;
    std::vector<double> sum(kLayers, 0), count(kLayers, 0);
    Outcome out{0, 0, 0};
    while (sim.state().time < 0.6) {
      sim.Step(0.6);
      out.iterations += uint64_t(sim.solver_stats().density_iterations +
                                 sim.solver_stats().divergence_iterations);
      const ParticleArrays& p = sim.state().particles;
      for (size_t i = 0; i < p.size(); ++i) {
        out.lowest_pressure = std::min(out.lowest_pressure, double(p.pressure[i]));
        const int layer = int(double(p.position[i].y()) / 0.02);
        if (layer >= 0 && layer < kLayers) {
          sum[size_t(layer)] += double(p.pressure[i]);
          count[size_t(layer)] += 1;
        }
      }
    }
    const double rho0_g = 1000 * 9.81, height = 0.3;
    for (int k = 0; k < kLayers; ++k) {
      if (count[size_t(k)] == 0) continue;
      const double expected = rho0_g * (height - 0.02 * (k + 0.5));
      const double error = std::abs(sum[size_t(k)] / count[size_t(k)] - expected);
      out.worst_error = std::max(out.worst_error, error / (rho0_g * height));
    }
    return out;
  };
  const Outcome one_signed = run(1, 0), signed_warm = run(1, 1), baseline = run(0.2, 0);
  std::printf(
      "warm_start 1: worst error %.2f%% one-signed, %.2f%% signed (%llu iterations; "
      "warm_start 0.2 one-signed: %.2f%%, %llu)\n",
      100 * one_signed.worst_error, 100 * signed_warm.worst_error,
      (unsigned long long)signed_warm.iterations, 100 * baseline.worst_error,
      (unsigned long long)baseline.iterations);
  EXPECT_LT(signed_warm.worst_error, 1.1 * baseline.worst_error);
  EXPECT_GT(one_signed.worst_error, 2 * baseline.worst_error);
  EXPECT_LT(signed_warm.iterations, baseline.iterations);
  // >= 0 up to the rounding of summing kappa_i dt of either sign (1e-6 of rho0 g H).
  EXPECT_GE(signed_warm.lowest_pressure, -1e-6 * 1000 * 9.81 * 0.3);
}

// Through the collapse, the impact on the obstacles and the run-up: every solve reaches its
// tolerance (none stops at the cap), the density error stays at the tolerance, and no
// particle leaves the domain (strictly inside: the clamp would put it on the wall) or enters
// an obstacle.
TEST(DfsphBoundaryTest, SolvesConvergeAndNoParticleLeaks) {
  Simulation sim(DamScene());
  const SphereObstacle sphere = sim.scene().spheres.at(0);
  const Aabb box = sim.scene().boxes.at(0).box;
  const Aabb domain = sim.model().domain;
  int max_iterations = 0;
  for (int f = 0; f < 24; ++f) {  // 0.4 s
    sim.StepFrame();
    ASSERT_TRUE(StateIsFinite(sim.state().particles));
    const SolverStats stats = sim.solver_stats();
    ASSERT_EQ(stats.capped_solves, 0u) << "frame " << f;
    ASSERT_LE(stats.density_error, sim.params().density_tolerance) << "frame " << f;
    max_iterations = std::max(max_iterations, stats.density_iterations);
    for (const Vec3& xf : sim.state().particles.position) {
      const Vec3d x = xf.cast<double>();
      for (int a = 0; a < 3; ++a) {
        ASSERT_GT(x[a], domain.min[a]) << "frame " << f;
        ASSERT_LT(x[a], domain.max[a]) << "frame " << f;
      }
      ASSERT_GT((x - sphere.center).norm(), sphere.radius) << "frame " << f;
      ASSERT_FALSE(box.Contains(x)) << "frame " << f;
    }
  }
  EXPECT_GE(max_iterations, 2);  // the solve did work
}

// The checkpoint hook (Solver::SaveArrays): a checkpoint holds the warm start under its names,
// one value per particle; the steps after a restore read it (without it they start cold and
// take another path), and restoring it reproduces them bit for bit.
TEST(DfsphCheckpointTest, HoldsTheWarmStartWhichTheNextStepsRead) {
  Simulation sim(DamScene());
  for (int i = 0; i < 20; ++i) sim.Step();
  const Checkpoint checkpoint = sim.SaveCheckpoint();
  const size_t n = sim.particle_count();
  ASSERT_EQ(checkpoint.solver_arrays.size(), 2u);
  EXPECT_EQ(checkpoint.solver_arrays[0].name, dfsph::kDensityStiffness);
  EXPECT_EQ(checkpoint.solver_arrays[1].name, dfsph::kDivergenceStiffness);
  for (const SolverArray& array : checkpoint.solver_arrays) {
    ASSERT_EQ(array.values.size(), n) << array.name;
    EXPECT_TRUE(std::any_of(array.values.begin(), array.values.end(), [](Real v) { return v > 0; }))
        << array.name;
  }
  EXPECT_EQ(DataOf(sim).density_stiffness, checkpoint.solver_arrays[0].values);
  auto steps_from = [&](const Checkpoint& start) {
    sim.RestoreCheckpoint(start);
    for (int i = 0; i < 5; ++i) sim.Step();
    return StateHash(sim.state());
  };
  const uint64_t warm = steps_from(checkpoint);
  Checkpoint cold = checkpoint;
  cold.solver_arrays.clear();
  EXPECT_NE(steps_from(cold), warm);
  EXPECT_EQ(steps_from(checkpoint), warm);
}

TEST(DfsphDiagnosticsTest, ReachingTheIterationCapIsCounted) {
  Scene scene = DamScene();
  SetParam(scene.params, "max_iterations", 1);
  SetParam(scene.params, "density_tolerance", 1e-7);
  Simulation sim(scene);
  for (int i = 0; i < 20; ++i) sim.Step();
  EXPECT_GT(sim.solver_stats().capped_solves, 0u);
  EXPECT_EQ(sim.solver_stats().density_iterations, 1);
  // And said: the run goes on, with a warning that names the limit and what to change.
  EXPECT_THAT(sim.warning(), ::testing::HasSubstr("solve stopped at max_iterations = 1"));
  EXPECT_THAT(sim.warning(), ::testing::HasSubstr("raise max_iterations"));
  EXPECT_EQ(sim.alarm(), "");
  // Within the solver's CFL limit the solves converge and nothing is said.
  Scene within = DamScene();
  SetParam(within.params, "cfl_factor", 0.3);
  Simulation converged(within);
  for (int i = 0; i < 20; ++i) converged.Step();
  EXPECT_EQ(converged.solver_stats().capped_solves, 0u);
  EXPECT_EQ(converged.warning(), "");
}

}  // namespace
}  // namespace dysa
