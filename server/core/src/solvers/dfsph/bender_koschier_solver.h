// Divergence-free SPH: Bender, Koschier 2015, "Divergence-free smoothed particle hydrodynamics"
// (SCA), and 2017, "Divergence-free SPH for incompressible and highly viscous fluids", IEEE
// TVCG 23(3), Algorithm 1.
//
// Same discretisation as wcsph (becker_teschner_solver.h): cubic spline of support 2 d, mass
// rho0 d^3, the Akinci boundary particles of boundary_particles.h with the pressure of the fluid
// around them (pressure_boundary.h), laminar viscosity, the inelastic wall contact,
// CFL-adaptive step (without a speed of sound: dt <= lambda d / v_max). Instead of an equation
// of state two solvers find the pressure (as kappa_i = p_i / rho_i):
//   factor       alpha_i = rho_i / (|sum_j m grad W_ij + sum_b Psi_b grad W_ib|^2
//                                   + sum_j |m grad W_ij|^2)                       (eq. 11)
//   acceleration a_i = -sum_j m (kappa_i / rho_i + kappa_j / rho_j) grad W_ij
//                      -sum_b Psi_b (kappa_i / rho_i + kappa_b / rho_b) grad W_ib
//                with kappa_b extrapolated from the fluid (plus a fixed hydrostatic part)
//   divergence   kappa_i = (1 / dt) max(D rho_i / Dt, 0) alpha_i where rho_i >= rho0 (0 below:
//                a free surface or spray may close in until compressed), with
//                D rho_i / Dt = sum_j m (v_i - v_j) . grad W_ij + sum_b Psi_b v_i . grad W_ib,
//                iterated until mean (D rho / Dt) dt / rho0 <= divergence_tolerance  (eq. 15)
//   density      kappa_i = (max(rho*_i, rho0) - rho0) / dt^2 alpha_i with the predicted
//                rho*_i = rho_i + dt D rho_i / Dt, iterated until mean (rho* - rho0) / rho0 <=
//                density_tolerance                                                 (eq. 17)
// each at least twice and at most max_iterations times (SolverStats counts the solves that
// stopped at the cap). The step, in the order of the passes:
//   neighbours, rho, alpha; the boundary's fluid neighbours; divergence solve on v;
//   non-pressure accelerations; dt;
//   v += dt a; density solve; x += dt v.
// Positions stay put from the density pass to x += dt v, so that pass lists every pair within
// the support with its grad W (BenderKoschierData::fluid_pairs, boundary_pairs), and the solves'
// sweeps read the lists instead of searching the grid again (the same pairs in the same order: the
// results are those of a grid search, bit for bit). The solver's data: bender_koschier_data.h. The
// pressure reported (p_i, which the probes read) is both solves' velocity change over the step
// taken as one acceleration, p_i = mu rho_i sum kappa_i dt_solve / dt, with mu the gradient moment
// of kernels.h as in wcsph. Warm start (2017, Sec. 4.4): each solve first applies the fraction
// warm_start (0.2) of what it applied in the previous step, then iterates on the error left.
// Its iterations only add pressure (kappa >= 0, in full steps), so a solve cannot take an
// overshoot back and stops nearer the warm start: more is faster and less accurate (0.5 left
// the tank at 0.02 m 2.2% off rho0 g H, 0.2 0.74%; 0.3 failed the stress test of particles
// started on top of each other). With signed_corrections an iteration applies half the kappa_i
// the error asks for, of either sign, and holds the solve's total >= 0 (a projected, relaxed
// Jacobi iteration, as IISPH's omega 0.5 with p >= 0): what the warm start over-applies is
// taken back, so warm_start 1 is usable (23.6 density iterations a step at 1 M particles against
// 39.6; bench/README.md). The solves' totals are carried per particle as
// kappa dt^2 and kappa dt (BenderKoschierData::density_stiffness, divergence_stiffness), which do
// not depend on the step size, and permuted with the particles; a checkpoint holds them
// (SaveArrays). Without it (0) every step rebuilds the hydrostatic pressure from zero: twice the
// iterations for a column at rest (tests/core). The divergence solve's stopping test uses the CFL
// step of the current velocities (a function of the state), so a checkpoint reproduces the
// following steps bit for bit. The mean errors of the stopping tests are sums of fixed-point
// integers (fixed_point_sum.h), exact in any order, so the iteration counts do not depend on the
// thread count nor on the number of processes a run is spread over (State::share: across
// processes the solves skip the ghosts in their sums and maxima, combine them over the processes,
// and refresh the ghosts' velocities after every update of the velocities).
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "dysa/core/solver.h"
#include "solvers/dfsph/bender_koschier_data.h"

namespace dysa::dfsph {

class BenderKoschierSolver final : public Solver {
 public:
  std::vector<Pass> BuildPasses(const Model& model) override;
  void Reset(size_t particles) override;
  std::vector<SolverArray> SaveArrays() const override;
  void RestoreArrays(std::span<const SolverArray> arrays, size_t particles) override;
  SolverStats stats() const override { return data_.stats; }
  const BenderKoschierData& data() const { return data_; }

 private:
  BenderKoschierData data_;
};

// The names of the warm start's arrays in a checkpoint (SolverArray::name).
inline constexpr std::string_view kDensityStiffness = "density_stiffness";
inline constexpr std::string_view kDivergenceStiffness = "divergence_stiffness";

std::unique_ptr<Solver> CreateBenderKoschierSolver();

// The step's warnings, shared with the GPU backend: a solve that stopped at its iteration cap
// (`error` and `tolerance` as fractions), and `limited` particles slowed to particle_spacing / dt.
std::string CapWarning(const char* solve, int iterations, double error, double tolerance,
                       uint64_t step);
std::string SpeedLimitWarning(uint64_t limited, uint64_t step);

}  // namespace dysa::dfsph
