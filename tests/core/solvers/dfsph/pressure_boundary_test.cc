// Tests of dfsph's pressure boundary (server/core/src/solvers/dfsph/pressure_boundary.h): the
// boundary's fluid neighbours are exactly the density pass's pairs seen from the boundary, in
// the same order for any thread count; Shepard weights are a partition of unity, so a uniform
// kappa extrapolates to itself; the hydrostatic part is the head of the fluid above the floor
// and never negative.
#include "solvers/dfsph/pressure_boundary.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <tuple>
#include <utility>
#include <vector>

#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "solvers/dfsph/bender_koschier_solver.h"
#include "solvers/physical/boundary_particles.h"
#include "support/with_threads.h"

namespace dysa {
namespace {

using dysa::testing::WithThreads;

// dfsph's own data (the boundary's neighbours) of a CPU simulation.
const dfsph::BenderKoschierData& DataOf(const Simulation& sim) {
  return dynamic_cast<const dfsph::BenderKoschierSolver&>(*sim.solver()).data();
}

// A resting block 0.2 m deep on the floor of a box, under g = 9.81 from the start.
Scene RestingBlock() {
  return ParseScene(R"({
    "domain": {"min": [0, 0, 0], "max": [0.2, 0.4, 0.08]},
    "fluid_blocks": [{"center": [0.1, 0.1, 0.04], "size": [0.2, 0.2, 0.08]}],
    "solver": "dfsph",
    "params": {"gravity": -9.81, "particle_spacing": 0.02, "max_time_step": 0.002}
  })");
}

TEST(PressureBoundaryTest, ListsEveryBoundaryPairOnceFromTheBoundarySide) {
  Simulation sim(RestingBlock());
  sim.Step();
  const dfsph::BenderKoschierData& s = DataOf(sim);
  const auto& bn = s.boundary_neighbors;
  std::set<std::pair<uint32_t, uint32_t>> from_fluid, from_boundary;
  for (size_t i = 0; i + 1 < s.boundary_pairs.begin.size(); ++i) {
    for (size_t k = s.boundary_pairs.begin[i]; k < s.boundary_pairs.begin[i + 1]; ++k) {
      from_fluid.insert({s.boundary_pairs.other[k], uint32_t(i)});
    }
  }
  ASSERT_GT(from_fluid.size(), 0u);
  for (size_t b = 0; b + 1 < bn.begin.size(); ++b) {
    for (size_t k = bn.begin[b]; k < bn.begin[b + 1]; ++k) {
      EXPECT_TRUE(from_boundary.insert({uint32_t(b), bn.fluid[k]}).second) << "twice: " << b;
      if (k > bn.begin[b]) {
        EXPECT_LT(bn.fluid[k - 1], bn.fluid[k]) << "not in fluid order";
      }
    }
  }
  EXPECT_EQ(from_fluid, from_boundary);
}

TEST(PressureBoundaryTest, ShepardWeightsSumToOneAndAUniformKappaExtrapolatesToItself) {
  Simulation sim(RestingBlock());
  sim.Step();
  const State& state = sim.state();
  dfsph::BoundaryNeighbors bn = DataOf(sim).boundary_neighbors;
  int with_fluid = 0;
  for (size_t b = 0; b + 1 < bn.begin.size(); ++b) {
    if (bn.begin[b] == bn.begin[b + 1]) continue;
    ++with_fluid;
    double sum = 0;
    for (size_t k = bn.begin[b]; k < bn.begin[b + 1]; ++k) sum += bn.weight[k];
    EXPECT_NEAR(sum, 1.0, 1e-5) << "boundary particle " << b;
  }
  EXPECT_GT(with_fluid, 100);
  const std::vector<Real> uniform(state.particles.size(), Real(3.5));
  dfsph::ExtrapolateKappa(uniform.data(), bn);
  for (size_t b = 0; b + 1 < bn.begin.size(); ++b) {
    const double expected = bn.begin[b] == bn.begin[b + 1] ? 0.0 : 3.5;
    EXPECT_NEAR(bn.kappa[b], expected, 1e-4) << "boundary particle " << b;
  }
}

// A boundary particle's hydrostatic part is rho g times how far its fluid neighbours are above
// it, Shepard-weighted: under the floor, rho0 g (mean height - y_b) with the density within 1%
// of rho0 at the first step; the side walls' particles above the fluid's mean height would
// take a negative head and are clamped at 0.
TEST(PressureBoundaryTest, TheHydrostaticPartIsTheHeadAboveTheBoundaryAndNeverNegative) {
  Simulation sim(RestingBlock());
  sim.Step();
  const State& s = sim.state();
  const BoundaryParticles& boundary = *DataOf(sim).boundary;
  const auto& bn = DataOf(sim).boundary_neighbors;
  ASSERT_EQ(bn.hydrostatic.size(), boundary.size());
  const double rho_g = 1000 * 9.81;
  int under_floor = 0, above = 0;
  for (size_t b = 0; b < boundary.size(); ++b) {
    EXPECT_GE(bn.hydrostatic[b], 0) << "boundary particle " << b;
    if (bn.begin[b] == bn.begin[b + 1]) continue;
    const double yb = boundary.grid().ys()[b];
    double mean_height = 0;
    for (size_t k = bn.begin[b]; k < bn.begin[b + 1]; ++k) {
      mean_height += bn.weight[k] * s.particles.position[bn.fluid[k]].y();
    }
    if (yb < 0) {
      EXPECT_NEAR(bn.hydrostatic[b], rho_g * (mean_height - yb), 0.01 * rho_g * (mean_height - yb))
          << "boundary particle " << b << " at y = " << yb;
      ++under_floor;
    } else if (yb > mean_height + 1e-4) {
      EXPECT_EQ(bn.hydrostatic[b], 0) << "boundary particle " << b << " at y = " << yb;
      ++above;
    }
  }
  EXPECT_GT(under_floor, 20);
  EXPECT_GT(above, 20);
}

TEST(PressureBoundaryTest, OneAndTwoThreadsListTheSameNeighboursAndWeights) {
  auto run = [](int threads) {
    return WithThreads(threads, [] {
      Simulation sim(RestingBlock());
      for (int i = 0; i < 5; ++i) sim.Step();
      const auto& bn = DataOf(sim).boundary_neighbors;
      return std::make_tuple(bn.begin, bn.fluid, bn.weight, bn.hydrostatic);
    });
  };
  EXPECT_EQ(run(1), run(2));
}

}  // namespace
}  // namespace dysa
