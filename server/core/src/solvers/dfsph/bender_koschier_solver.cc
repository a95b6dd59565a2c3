#include "solvers/dfsph/bender_koschier_solver.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "dysa/core/fixed_point_sum.h"
#include "dysa/core/kernels.h"
#include "solvers/dfsph/pressure_boundary.h"
#include "solvers/domain_walls.h"
#include "solvers/physical/cfl_time_step.h"
#include "solvers/physical/physical_passes.h"
#include "sph_loops.h"

namespace dysa::dfsph {
namespace {

// The solves' per-particle arrays, in data.work: alpha_i, kappa_i of the current iteration, the
// error of particle i, and sum kappa_i dt over the iterations both solves applied this step
// (for p_i).
struct Work {
  Real* alpha;
  Real* kappa;
  Real* error;
  Real* kappa_sum;
};

Work Arrays(BenderKoschierData& data, const State& state) {
  const size_t n = state.particles.size();
  data.work.resize(4 * n);
  Real* base = data.work.data();
  return {base, base + n, base + 2 * n, base + 3 * n};
}

// One thread's pairs, for its block of particles, before they are laid end to end.
struct PairBlock {
  std::vector<uint32_t> other;
  std::vector<Vec3> grad_w;
  void Add(uint32_t j, const Vec3& g) {
    other.push_back(j);
    grad_w.push_back(g);
  }
};

// Lays the threads' blocks end to end: `begin[i + 1]` holds the count of the thread's pairs up
// to and with particle i (its block is [lo, hi)), made global here by adding the blocks before.
// The layout does not depend on the thread count. Call inside the parallel region, by all.
void JoinPairBlocks(const PairBlock& block, int64_t lo, int64_t hi, std::vector<size_t>& sizes,
                    NeighborPairs& pairs) {
  const int t = omp_get_thread_num();
  sizes[t] = block.other.size();
#pragma omp barrier
  size_t base = 0;
  for (int u = 0; u < t; ++u) base += sizes[u];
#pragma omp single
  {
    size_t total = 0;
    for (size_t s : sizes) total += s;
    pairs.other.resize(total);
    pairs.grad_w.resize(total);
    pairs.begin[0] = 0;
  }  // implicit barrier: the arrays are sized
  for (int64_t i = lo; i < hi; ++i) pairs.begin[i + 1] += base;
  std::copy(block.other.begin(), block.other.end(), pairs.other.begin() + base);
  std::copy(block.grad_w.begin(), block.grad_w.end(), pairs.grad_w.begin() + base);
}

// rho_i and alpha_i; lists the step's pairs (data.fluid_pairs, data.boundary_pairs).
void DensityAndFactor(const Model& model, BenderKoschierData& data, State& state) {
  const BoundaryParticles& boundary = *data.boundary;
  ParticleArrays& p = state.particles;
  const Work w = Arrays(data, state);
  const PhysicalKernel<Real> kernel = model.Kernel();
  const Real support = kernel.support;
  const Real mass = Real(model.particle_mass);
  const Real rho0 = Real(model.params.rest_density);
  const Real density_scale = Real(1 / model.density_moment);  // the rest lattice has rho0
  const Real* volume = boundary.padded_volume();
  const int64_t n = int64_t(p.size());
  NeighborPairs& fluid_pairs = data.fluid_pairs;
  NeighborPairs& wall_pairs = data.boundary_pairs;
  fluid_pairs.begin.resize(n + 1);
  wall_pairs.begin.resize(n + 1);
  // The blocks' sizes, one per thread, kept by the calling thread like the blocks by theirs.
  // Referred to by reference in the region: a thread_local named there is each thread's own.
  thread_local std::vector<size_t> fluid_block_sizes, wall_block_sizes;
  std::vector<size_t>& fluid_sizes = fluid_block_sizes;
  std::vector<size_t>& wall_sizes = wall_block_sizes;
  fluid_sizes.assign(omp_get_max_threads(), 0);
  wall_sizes.assign(omp_get_max_threads(), 0);
#pragma omp parallel
  {
    // Kept between steps by the pool's threads, so a step allocates nothing once warm.
    thread_local PairBlock fluid_block, wall_block;
    fluid_block.other.clear();
    fluid_block.grad_w.clear();
    wall_block.other.clear();
    wall_block.grad_w.clear();
    const int t = omp_get_thread_num(), threads = omp_get_num_threads();
    const int64_t lo = n * t / threads, hi = n * (t + 1) / threads;
    for (int64_t i = lo; i < hi; ++i) {
      const Eigen::Vector3i cell = state.grid.SortedCell(uint32_t(i));
      const Vec3& x = p.position[i];
      Real fluid = 0, squares = 0;
      Vec3 grad = Vec3::Zero();
      ForEachWithin(state.grid, cell, x, support, [&](uint32_t j, const Vec3& xij, Real r) {
        fluid += kernel.W(r);
        const Vec3 g = GradW(xij, r, kernel);
        if (r > 0) fluid_block.Add(j, g);
        const Vec3 mg = mass * g;
        grad += mg;
        squares += mg.squaredNorm();
      });
      Real wall = 0;
      ForEachWithin(boundary.grid(), cell, x, support, [&](uint32_t b, const Vec3& xib, Real r) {
        wall += volume[b] * kernel.W(r);
        const Vec3 g = GradW(xib, r, kernel);
        if (r > 0) wall_block.Add(b, g);
        grad += (rho0 * volume[b]) * g;
      });
      fluid_pairs.begin[i + 1] = fluid_block.other.size();
      wall_pairs.begin[i + 1] = wall_block.other.size();
      const Real rho = (mass * fluid + rho0 * wall) * density_scale;
      p.density[i] = rho;
      const Real denominator = grad.squaredNorm() + squares;
      // A particle without neighbours has no pressure to solve for.
      w.alpha[i] =
          denominator > Real(1e-6) * rho * rho / (support * support) ? rho / denominator : 0;
    }
    JoinPairBlocks(fluid_block, lo, hi, fluid_sizes, fluid_pairs);
    JoinPairBlocks(wall_block, lo, hi, wall_sizes, wall_pairs);
  }
}

// D rho_i / Dt = sum_j m (v_i - v_j) . grad W_ij + sum_b Psi_b v_i . grad W_ib, over the
// step's pairs (the grid's neighbours at distance > 0, in the grid's order).
Real DensityRate(const Model& model, const BenderKoschierData& data, const State& state,
                 int64_t i) {
  const ParticleArrays& p = state.particles;
  const Real mass = Real(model.particle_mass);
  const Real rho0 = Real(model.params.rest_density);
  const Real* volume = data.boundary->padded_volume();
  const NeighborPairs& fluid = data.fluid_pairs;
  const NeighborPairs& wall = data.boundary_pairs;
  const Vec3& v = p.velocity[i];
  Real rate = 0;
  for (size_t k = fluid.begin[i]; k < fluid.begin[i + 1]; ++k) {
    rate += mass * (v - p.velocity[fluid.other[k]]).dot(fluid.grad_w[k]);
  }
  // A moving obstacle's samples carry its velocity v_b: the term is Psi_b (v_i - v_b) . grad W.
  const std::span<const Vec3> wall_velocity = data.boundary->velocity();
  if (wall_velocity.empty()) {
    for (size_t k = wall.begin[i]; k < wall.begin[i + 1]; ++k) {
      rate += rho0 * volume[wall.other[k]] * v.dot(wall.grad_w[k]);
    }
  } else {
    for (size_t k = wall.begin[i]; k < wall.begin[i + 1]; ++k) {
      const uint32_t b = wall.other[k];
      rate += rho0 * volume[b] * (v - wall_velocity[b]).dot(wall.grad_w[k]);
    }
  }
  return rate;
}

// The largest density error, as a fraction of rho0, that one iteration of the density solve
// corrects (a converged running fluid has errors of 1e-4).
constexpr double kMaxCorrection = 0.05;

// v_i -= dt [sum_j m (kappa_i / rho_i + kappa_j / rho_j) grad W_ij
//            + sum_b Psi_b (kappa_i / rho_i + kappa_b / rho_b) grad W_ib], from the kappa of
// every particle, extrapolated to the boundary (pressure_boundary.h);
// kappa_sum_i += kappa_i dt and applied_i += kappa_i (the solve's total, for its warm start).
void ApplyKappa(const Model& model, BenderKoschierData& data, State& state, Real dt,
                Real* applied) {
  ParticleArrays& p = state.particles;
  const Work w = Arrays(data, state);
  const Real mass = Real(model.particle_mass);
  const Real rho0 = Real(model.params.rest_density);
  const Real* volume = data.boundary->padded_volume();
  const int64_t n = int64_t(p.size());
  // kappa_j / rho_j, read by the neighbours; in the error array, free until the next iteration.
#pragma omp parallel for schedule(static)
  for (int64_t j = 0; j < n; ++j) w.error[j] = w.kappa[j] / p.density[j];
  ExtrapolateKappa(w.error, data.boundary_neighbors);
  const Real* kappa_b = data.boundary_neighbors.kappa.data();
  const NeighborPairs& fluid_pairs = data.fluid_pairs;
  const NeighborPairs& wall_pairs = data.boundary_pairs;
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    const Real ki = w.error[i];
    Vec3 fluid = Vec3::Zero(), wall = Vec3::Zero();
    for (size_t k = fluid_pairs.begin[i]; k < fluid_pairs.begin[i + 1]; ++k) {
      fluid += (ki + w.error[fluid_pairs.other[k]]) * fluid_pairs.grad_w[k];
    }
    for (size_t k = wall_pairs.begin[i]; k < wall_pairs.begin[i + 1]; ++k) {
      const uint32_t b = wall_pairs.other[k];
      wall += (volume[b] * (ki + kappa_b[b])) * wall_pairs.grad_w[k];
    }
    p.velocity[i] -= dt * (mass * fluid + rho0 * wall);
    w.kappa_sum[i] += w.kappa[i] * dt;
    applied[i] += w.kappa[i];
  }
  // Across processes the next iteration's rates read the neighbours' velocities, which a ghost's
  // own update got wrong near the ghost layer's far edge (its neighbourhood is cut there): each
  // ghost takes its owner's (ProcessShare::refresh_ghosts; distributed_simulation.cc says why).
  state.share.RefreshGhosts(p.velocity);
}

// A solve's warm start: kappa_i = warm_start carried_i / dt^2 (density) or / dt (the previous
// step's total, carried free of the step size), applied at once; carried then accumulates this
// step's total in kappa units, which FinishWarmStart turns back into carried form. Only particles
// that are being compressed now start warm (as in SPlisHSPlasH), and by at most the one-iteration
// bound kMaxCorrection: a particle that has already moved apart would otherwise be pushed again
// by its previous pressure (tests/stress: particles started on top of each other blew apart).
void StartWarmStart(const Model& model, BenderKoschierData& data, State& state, Real dt,
                    bool density_solve, Real* carried) {
  const ParticleArrays& p = state.particles;
  const Work w = Arrays(data, state);
  const int64_t n = int64_t(p.size());
  const Real rho0 = Real(model.params.rest_density);
  const Real scale = Real(model.params.warm_start) / (density_solve ? dt * dt : dt);
  const Real bound = Real(kMaxCorrection) * rho0 / (dt * dt);
  if (scale == 0) {  // off: nothing to apply, only the accumulator to clear
    std::fill(carried, carried + n, Real(0));
    return;
  }
  bool any = false;
#pragma omp parallel for schedule(static) reduction(|| : any)
  for (int64_t i = 0; i < n; ++i) {
    Real kappa = 0;
    if (carried[i] > 0) {  // the rate only where there is something to start from
      const Real rate = DensityRate(model, data, state, i);
      const bool compressing =
          density_solve ? p.density[i] + dt * rate > rho0 : rate > 0 && p.density[i] >= rho0;
      if (compressing) kappa = std::min(scale * carried[i], bound * w.alpha[i]);
    }
    w.kappa[i] = kappa;
    carried[i] = 0;
    any = any || kappa > 0;
  }
  // Applied on every process or on none, as ApplyKappa refreshes the ghosts (a collective).
  double applies = any ? 1 : 0;
  state.share.MaxOverProcesses({&applies, 1});
  if (applies > 0) ApplyKappa(model, data, state, dt, carried);
}

void FinishWarmStart(const State& state, Real dt, bool density_solve, Real* carried) {
  const int64_t n = int64_t(state.particles.size());
  const Real scale = density_solve ? dt * dt : dt;
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) carried[i] *= scale;
}

// With signed corrections, the fraction of its kappa_i that an iteration applies. Each pair's
// velocity change carries kappa_i + kappa_j, so the mode in which neighbours alternate is
// corrected twice over: a one-signed solve cuts that overshoot off (it never takes pressure
// back), a signed one would swing on it without decay. Half steps, as IISPH's relaxed Jacobi
// (omega 0.5, Ihmsen et al. 2014), damp it (with full steps the quick tank's density ended 10.6%
// off rho0; bench/README.md, "Signed corrections", has the other steps tried).
constexpr Real kSignedStep = 0.5;

// With signed corrections (Params::signed_corrections) a solve's iteration asks particle i for
// the density change `difference` (a compression > 0, or its rate) and applies kappa_i, held at
// -applied_i or above so that the solve's total stays >= 0. Its error is what this iteration
// corrects: the compression, or the expansion that kappa_i < 0 takes back (kappa over
// `per_density`, the factor from density to kappa; kappa < 0 needs alpha_i > 0). A particle
// that expands without pressure to release is, as in the one-signed solve, no error.
inline Real TakenBack(Real difference, Real kappa, Real per_density) {
  if (difference > 0) return difference;
  return kappa < 0 ? -kappa / per_density : Real(0);
}

// The mean over the owned particles of error[i] times `factor` (the solve's error as a fraction
// of rho0): the stopping test, which decides the iteration count. Summed as fixed-point integers
// (fixed_point_sum.h), over the threads and then over the processes: the same bits for any
// thread count and on any number of processes, so every process stops at the same iteration,
// the one a single process stops at.
double MeanError(const State& state, const Real* error, double factor) {
  const ProcessShare& share = state.share;
  const uint8_t* ghost = share.GhostFlags();
  const size_t n = state.particles.size();
  // The owned count: every particle on one process, without a pass over them per iteration.
  const int64_t owned = ghost ? int64_t(std::count(ghost, ghost + n, uint8_t{0})) : int64_t(n);
  int64_t sums[2] = {FixedPointSum(error, n, factor, ghost), owned};
  share.SumOverProcesses(sums);
  return sums[1] > 0 ? FromFixedPoint(sums[0]) / double(sums[1]) : 0;
}

// The fastest owned particle over the processes (a maximum: exact in any order).
double MaxSpeed(const State& state) {
  const uint8_t* ghost = state.share.GhostFlags();
  const std::vector<Vec3>& velocity = state.particles.velocity;
  Real v2 = 0;
  for (size_t i = 0; i < velocity.size(); ++i) {
    if (!(ghost && ghost[i])) v2 = std::max(v2, velocity[i].squaredNorm());
  }
  double max = double(v2);
  state.share.MaxOverProcesses({&max, 1});
  return std::sqrt(max);
}

void DivergenceSolve(const Model& model, BenderKoschierData& data, State& state) {
  ParticleArrays& p = state.particles;
  const Work w = Arrays(data, state);
  const int64_t n = int64_t(p.size());
  const double rho0 = model.params.rest_density;
  // The step these velocities will be integrated with, as the time_step pass will choose it
  // (up to the frame's end): a function of the state, so nothing is carried between steps.
  const double dt = std::min(CflLimits(model, std::max(MaxSpeed(state), data.max_obstacle_speed),
                                       std::abs(model.params.gravity), false)
                                 .Min(),
                             model.params.max_time_step);
  const Real inv_dt = Real(1 / dt);
  const bool signed_corrections = model.params.signed_corrections != 0;
  std::fill(w.kappa_sum, w.kappa_sum + n, Real(0));
  Real* carried = data.divergence_stiffness.data();
  StartWarmStart(model, data, state, Real(dt), false, carried);
  SolverStats& stats = data.stats;
  int iteration = 0;
  for (;; ++iteration) {
#pragma omp parallel for schedule(static)
    for (int64_t i = 0; i < n; ++i) {
      // Only fluid at rest density or above is held divergence-free: a particle below it (a
      // free surface, spray) may still close in on its neighbours until it is compressed, where
      // the density solve takes over (SPlisHSPlasH leaves out particles with too few neighbours
      // for the same reason). Held too, spray pushed apart spray and gained energy: particles
      // started on top of each other reached 12 times what the start released (stress_bench).
      if (signed_corrections) {
        const Real rate = p.density[i] >= rho0 ? DensityRate(model, data, state, i) : Real(0);
        const Real kappa = std::max(kSignedStep * rate * w.alpha[i] * inv_dt, -carried[i]);
        w.kappa[i] = kappa;
        w.error[i] = TakenBack(rate, kappa, kSignedStep * w.alpha[i] * inv_dt);
        continue;
      }
      const Real rate =
          p.density[i] >= rho0 ? std::max(DensityRate(model, data, state, i), Real(0)) : Real(0);
      w.error[i] = rate;
      w.kappa[i] = rate * w.alpha[i] * inv_dt;
    }
    stats.divergence_error = MeanError(state, w.error, dt / rho0);
    if (iteration >= 2 && stats.divergence_error <= model.params.divergence_tolerance) break;
    if (iteration == model.params.max_iterations) {
      ++stats.capped_solves;
      state.warning = CapWarning("divergence", iteration, stats.divergence_error,
                                 model.params.divergence_tolerance, state.step + 1);
      break;
    }
    ApplyKappa(model, data, state, Real(dt), carried);
  }
  FinishWarmStart(state, Real(dt), false, carried);
  stats.divergence_iterations = iteration;
}

void DensitySolve(const Model& model, BenderKoschierData& data, State& state) {
  ParticleArrays& p = state.particles;
  const Work w = Arrays(data, state);
  const int64_t n = int64_t(p.size());
  const Real rho0 = Real(model.params.rest_density);
  const Real dt = Real(state.dt);
  const Real inv_dt2 = 1 / (dt * dt);
  const Real cap = Real(kMaxCorrection) * rho0;
  const bool signed_corrections = model.params.signed_corrections != 0;
  Real* carried = data.density_stiffness.data();
  StartWarmStart(model, data, state, dt, true, carried);
  SolverStats& stats = data.stats;
  int iteration = 0;
  for (;; ++iteration) {
#pragma omp parallel for schedule(static)
    for (int64_t i = 0; i < n; ++i) {
      // Only compression is an error: a free surface's kernel deficit is not.
      const Real predicted = p.density[i] + dt * DensityRate(model, data, state, i);
      if (signed_corrections) {
        const Real difference = predicted - rho0;
        const Real bounded = std::clamp(difference, -cap, cap);
        const Real kappa = std::max(kSignedStep * bounded * inv_dt2 * w.alpha[i], -carried[i]);
        w.kappa[i] = kappa;
        w.error[i] = TakenBack(difference, kappa, kSignedStep * inv_dt2 * w.alpha[i]);
        continue;
      }
      const Real excess = std::max(predicted - rho0, Real(0));
      w.error[i] = excess;
      // A compression far beyond any the solve meets in a running fluid (particles started on
      // top of each other, a step past the stability limit) is corrected by at most
      // kMaxCorrection rho0 per step, over several steps: removing it in one would turn it into
      // velocities that blow the fluid apart.
      w.kappa[i] = std::min(excess, cap) * inv_dt2 * w.alpha[i];
    }
    stats.density_error = MeanError(state, w.error, 1 / double(rho0));
    if (iteration >= 2 && stats.density_error <= model.params.density_tolerance) break;
    if (iteration == model.params.max_iterations) {
      ++stats.capped_solves;
      state.warning = CapWarning("density", iteration, stats.density_error,
                                 model.params.density_tolerance, state.step + 1);
      break;
    }
    ApplyKappa(model, data, state, dt, carried);
  }
  FinishWarmStart(state, dt, true, carried);
  stats.density_iterations = iteration;
  // The step's pressure (the probes read it): both solves' velocity changes taken as one
  // acceleration over the step, p_i = rho_i sum kappa_i dt_solve / dt. The divergence solve's
  // part is not small: at rest it holds part of the weight. Times the gradient moment (kernels.h):
  // the pressure whose exact gradient the discrete forces are, as wcsph divides its forces by it;
  // scaling the forces and alpha instead would give the same iterates.
  const Real scale = Real(model.gradient_moment) / dt;
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) p.pressure[i] = scale * w.kappa_sum[i] * p.density[i];
}

// Gravity, added to the walls' hydrostatic acceleration of the boundary_pressure pass.
void AddGravity(const Model& model, BenderKoschierData& data, State& state) {
  const Vec3 g(0, Real(physical::GravityAt(model.params, state.time)), 0);
  for (Vec3& a : data.acceleration) a += g;
}

void PredictVelocities(const Model&, BenderKoschierData& data, State& state) {
  ParticleArrays& p = state.particles;
  const Real dt = Real(state.dt);
  const int64_t n = int64_t(p.size());
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) p.velocity[i] += data.acceleration[i] * dt;
  // A ghost's acceleration misses what lies past the ghost layers; the density solve reads the
  // neighbours' velocities.
  state.share.RefreshGhosts(p.velocity);
}

// x += v dt, with the displacement of a step limited to one particle spacing: a particle that
// would jump further skips the neighbours whose pressure should have stopped it, and the next
// solve starts from a state it cannot repair (an unconverged solve past its iteration cap, a
// CFL factor beyond the stability limit, a start far above rest density). Such particles are
// slowed to d / dt and the step's warning says so; a converged step never comes near it (the
// CFL step keeps v dt <= cfl_factor d before the pressure solve).
void IntegratePositions(const Model& model, BenderKoschierData&, State& state) {
  ParticleArrays& p = state.particles;
  const Real dt = Real(state.dt);
  const Real limit = Real(model.params.particle_spacing / state.dt);
  const int64_t n = int64_t(p.size());
  const std::vector<physical::ObstacleFrame> frames =
      physical::ObstacleFramesOverStep(model, state.time, state.dt);
  const uint8_t* ghost = state.share.GhostFlags();
  int64_t limited = 0;
#pragma omp parallel for schedule(static) reduction(+ : limited)
  for (int64_t i = 0; i < n; ++i) {
    const Real speed2 = p.velocity[i].squaredNorm();
    if (speed2 > limit * limit) {
      p.velocity[i] *= limit / std::sqrt(speed2);
      if (!(ghost && ghost[i])) ++limited;  // a ghost is counted by its owner
    }
    physical::LimitApproachToSurfaces(model, frames, dt, p.position[i], p.velocity[i]);
    p.position[i] += p.velocity[i] * dt;
    CollideWithDomainWalls(model.domain, model.periodic, Real(0), p.position[i], p.velocity[i]);
  }
  state.share.SumOverProcesses({&limited, 1});
  if (limited > 0) state.warning = SpeedLimitWarning(uint64_t(limited), state.step + 1);
}

// The neighbour sort, which also carries the warm start along with the particles.
void SortIntoGrid(const Model& model, BenderKoschierData& data, State& state) {
  physical::SortIntoGrid(model, state);
  const size_t n = state.particles.size();
  if (data.density_stiffness.size() != n || data.divergence_stiffness.size() != n) {
    data.density_stiffness.assign(n, Real(0));  // particles the solver did not start: cold
    data.divergence_stiffness.assign(n, Real(0));
  }
  const auto order = state.grid.order();
  PermuteInPlace(order, data.density_stiffness, state.real_scratch);
  PermuteInPlace(order, data.divergence_stiffness, state.real_scratch);
}

}  // namespace

void BenderKoschierSolver::Reset(size_t particles) {
  data_.density_stiffness.assign(particles, Real(0));
  data_.divergence_stiffness.assign(particles, Real(0));
}

std::vector<SolverArray> BenderKoschierSolver::SaveArrays() const {
  return {{std::string(kDensityStiffness), data_.density_stiffness},
          {std::string(kDivergenceStiffness), data_.divergence_stiffness}};
}

void BenderKoschierSolver::RestoreArrays(std::span<const SolverArray> arrays, size_t particles) {
  Reset(particles);
  if (const auto* saved = FindSolverArray(arrays, kDensityStiffness, particles)) {
    data_.density_stiffness = *saved;
  }
  if (const auto* saved = FindSolverArray(arrays, kDivergenceStiffness, particles)) {
    data_.divergence_stiffness = *saved;
  }
}

std::vector<Pass> BenderKoschierSolver::BuildPasses(const Model& model) {
  data_.SampleBoundary(model);
  std::vector<Pass> passes;
  if (data_.boundary->HasMovingObstacles()) {
    passes.push_back(SolverPass("move_boundary", data_, physical::MoveBoundary));
  }
  passes.push_back(SolverPass("neighbour_grid", data_, SortIntoGrid));
  passes.push_back(SolverPass("density", data_, DensityAndFactor));
  passes.push_back(SolverPass("boundary_pressure", data_, ListBoundaryNeighbors));
  passes.push_back(SolverPass("divergence_solve", data_, DivergenceSolve));
  passes.push_back(SolverPass("external_forces", data_, AddGravity));
  if (model.params.kinematic_viscosity > 0) {
    passes.push_back(SolverPass("viscosity", data_, physical::AddViscosity));
    if (data_.boundary->HasNoSlip()) {
      passes.push_back(SolverPass("wall_viscosity", data_, physical::AddWallViscosity));
    }
  }
  passes.push_back(SolverPass("time_step", data_, ChooseIncompressibleTimeStepPass));
  passes.push_back(SolverPass("predict_velocity", data_, PredictVelocities));
  passes.push_back(SolverPass("density_solve", data_, DensitySolve));
  passes.push_back(SolverPass("integrate", data_, IntegratePositions));
  return passes;
}

std::unique_ptr<Solver> CreateBenderKoschierSolver() {
  return std::make_unique<BenderKoschierSolver>();
}

}  // namespace dysa::dfsph
