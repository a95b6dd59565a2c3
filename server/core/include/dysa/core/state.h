// The mutable state of a simulation: particles as flat arrays, one array per attribute.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "dysa/core/neighbor_grid.h"
#include "dysa/core/types.h"

namespace dysa {

// Particles are physically reordered by grid cell every step, so index i is not a particle's
// identity: id[i] is (its index at spawn time, stable for the whole run).
struct ParticleArrays {
  std::vector<uint32_t> id;
  std::vector<Vec3> position;       // m
  std::vector<Vec3> velocity;       // m/s
  std::vector<Vec3> predicted;      // m, position predicted for the force passes
  std::vector<Real> density;        // kg/m^3
  std::vector<Real> near_density;   // kg/m^3 (seed model, Clavet et al. 2005)
  std::vector<Real> pressure;       // Pa
  std::vector<Real> near_pressure;  // Pa
  // dfsph's warm start (Bender & Koschier 2017, Sec. 4.4): what each of its solves applied in the
  // previous step, as the time-step free kappa dt^2 (density solve, kg/m^3) and kappa dt
  // (divergence solve, kg/m^3). Empty for the other solvers. Not sized by Resize(): the solver
  // sizes it (Solver::InitState), and a checkpoint saves it since the next step reads it.
  std::vector<Real> density_stiffness;
  std::vector<Real> divergence_stiffness;

  size_t size() const { return id.size(); }
  void Resize(size_t n);
};

// The pairs within the kernel's support of each particle, with the pair's kernel gradient,
// listed by a pass that visits them anyway for the later passes of the same step that sweep
// them again while the positions stay put (dfsph's pressure solves: a dozen sweeps a step).
// A sweep of the list reads the ~30 pairs of a particle instead of testing the ~200 particles
// of its 27 grid cells. Pairs at distance 0 have no gradient and are left out.
struct NeighborPairs {
  std::vector<size_t> begin;    // n + 1 offsets: particle i's pairs are [begin[i], begin[i + 1])
  std::vector<uint32_t> other;  // the other particle's index in its own grid's storage order
  std::vector<Vec3> grad_w;     // 1/m^4, grad W(x_i - x_other)
};

struct State {
  ParticleArrays particles;
  NeighborGrid grid;
  // Scratch buffers reused across steps (never shrink, so a step allocates nothing).
  std::vector<Vec3> vec3_scratch;
  std::vector<Real> real_scratch;
  std::vector<uint32_t> index_scratch;
  // m/s^2, per particle in storage order: the physical solvers' accelerations of this step,
  // computed after the neighbour sort (so never carried across steps).
  std::vector<Vec3> acceleration;
  // Pa, per boundary particle of the physical solvers, extrapolated from the fluid each step.
  std::vector<Real> boundary_pressure;
  // m/s, per boundary particle of a no-slip wall: the fluid's velocity extrapolated to it,
  // mirrored (so that the velocity falls to 0 at the wall); 0 elsewhere. Per step.
  std::vector<Vec3> boundary_velocity;

  // s, the step being taken: Model::dt for a fixed-step solver, set before the passes; chosen
  // by a physical solver's time_step pass (CFL), at most max_dt. Both are rewritten every step
  // before they are read, so a checkpoint need not hold them.
  double dt = 0;
  double max_dt = 0;  // s, a cap on this step's dt from the caller (the end of a frame)

  // Diagnostics of an iterative pressure solver (dfsph): the latest step's iterations and
  // errors, and how many solves since the start stopped at max_iterations before reaching
  // their tolerance. Not part of a checkpoint: nothing reads them back.
  struct SolverStats {
    int density_iterations = 0;
    int divergence_iterations = 0;
    double density_error = 0;     // mean (rho - rho0) / rho0 at the end of the density solve
    double divergence_error = 0;  // mean (D rho / Dt) dt / rho0 at the end of the divergence solve
    uint64_t capped_solves = 0;
  } solver_stats;
  std::vector<Real> solver_scratch;  // per particle, the solvers' work arrays
  // dfsph's pairs of this step, fluid-fluid and fluid-boundary, listed by its density pass after
  // the neighbour sort. Rebuilt every step, so a checkpoint need not hold them.
  NeighborPairs fluid_pairs;
  NeighborPairs boundary_pairs;
  // boundary_pairs seen from the boundary (dfsph's pressure boundary, pressure_boundary.h):
  // boundary particle b's fluid neighbours i in [begin[b], begin[b + 1]), in fluid order, with
  // W(x_b - x_i) over sum_i W(x_b - x_i) (Shepard weights); per step, like the pairs.
  struct BoundaryNeighbors {
    std::vector<size_t> begin;
    std::vector<uint32_t> fluid;
    std::vector<Real> weight;
    std::vector<Real> hydrostatic;  // Pa, max(0, g . sum_i weight rho_i (x_b - x_i))
    std::vector<Real> kappa;        // kappa_b / rho, of the solve's current iteration
  } boundary_neighbors;
  std::vector<size_t> boundary_fill;  // scratch of the transpose

  // Set by a pass when its step could not hold the model's accuracy and the pass had to limit
  // it (the seed's velocity limiter, an iteration cap); the run goes on. Cleared at the start of
  // each frame (Simulation::StepFrame) and on reset.
  std::string warning;

  double time = 0;     // s, simulated
  uint64_t step = 0;   // steps since the last reset
  uint64_t frame = 0;  // frames (Simulation::StepFrame) since the last reset
};

// FNV-1a over ids, positions and velocities in id order: equal hashes mean bit-identical
// particle states whatever the storage order.
uint64_t StateHash(const State& state);

// True when every position and velocity is finite. A NaN or Inf means the step diverged; callers
// stop instead of integrating (or showing) garbage.
bool StateIsFinite(const ParticleArrays& particles);

}  // namespace dysa
