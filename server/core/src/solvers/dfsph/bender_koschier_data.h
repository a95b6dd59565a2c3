// What dfsph keeps besides the shared State (as SPlisHSPlasH's SimulationDataDFSPH): its warm
// start, the step's pair lists and the boundary's view of them, the solves' work arrays and
// statistics. Only the warm start outlives a step (SaveArrays); the rest is rebuilt by each step
// before it is read.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "dysa/core/solver.h"
#include "dysa/core/types.h"
#include "solvers/physical/physical_data.h"

namespace dysa::dfsph {

// The pairs within the kernel's support of each particle, with the pair's kernel gradient,
// listed by a pass that visits them anyway for the later passes of the same step that sweep
// them again while the positions stay put (the pressure solves: a dozen sweeps a step). A
// sweep of the list reads the ~30 pairs of a particle instead of testing the ~200 particles of
// its 27 grid cells. Pairs at distance 0 have no gradient and are left out.
struct NeighborPairs {
  std::vector<size_t> begin;    // n + 1 offsets: particle i's pairs are [begin[i], begin[i + 1])
  std::vector<uint32_t> other;  // the other particle's index in its own grid's storage order
  std::vector<Vec3> grad_w;     // 1/m^4, grad W(x_i - x_other)
};

// boundary_pairs seen from the boundary (pressure_boundary.h): boundary particle b's fluid
// neighbours i in [begin[b], begin[b + 1]), in fluid order, with W(x_b - x_i) over
// sum_i W(x_b - x_i) (Shepard weights).
struct BoundaryNeighbors {
  std::vector<size_t> begin;
  std::vector<uint32_t> fluid;
  std::vector<Real> weight;
  std::vector<Real> hydrostatic;  // Pa, max(0, g . sum_i weight rho_i (x_b - x_i))
  std::vector<Real> kappa;        // kappa_b / rho, of the solve's current iteration
  std::vector<size_t> fill;       // scratch of the transpose
};

struct BenderKoschierData : physical::PhysicalData {
  // The warm start (Bender & Koschier 2017, Sec. 4.4), per particle in storage order: what each
  // solve applied in the previous step, as the time-step free kappa dt^2 (density solve,
  // kg/m^3) and kappa dt (divergence solve, kg/m^3). Permuted with the particles by the
  // neighbour sort; a checkpoint holds them, since the next step reads them.
  std::vector<Real> density_stiffness;
  std::vector<Real> divergence_stiffness;
  // This step's pairs, fluid-fluid and fluid-boundary, listed by the density pass after the
  // neighbour sort, and the boundary's view of the latter (the boundary_pressure pass).
  NeighborPairs fluid_pairs;
  NeighborPairs boundary_pairs;
  BoundaryNeighbors boundary_neighbors;
  // Per particle, the solves' work arrays, 4 n values (bender_koschier_solver.cc).
  std::vector<Real> work;
  SolverStats stats;
};

}  // namespace dysa::dfsph
