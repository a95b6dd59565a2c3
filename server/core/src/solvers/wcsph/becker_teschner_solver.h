// Weakly compressible SPH: Becker, Teschner 2007, "Weakly compressible SPH for free surface
// flows", Proc. ACM SIGGRAPH/Eurographics Symposium on Computer Animation (SCA), 209-217.
//
// In SI units, with d = particle_spacing, support H = 2 d of the cubic spline (kernels.h),
// particle mass m = rho0 d^3:
//   density      carried by the continuity equation with a density diffusion term (delta-SPH):
//                D rho_i / Dt = sum_j m (v_i - v_j) . grad W_ij + sum_b Psi_b v_i . grad W_ib
//                             + delta h c0 sum_j psi_ij . grad W_ij m / rho_j,
//                psi_ij = 2 (rho_j - rho_i - rho^H_ij) (x_j - x_i) / |x_ij|^2,
//                rho^H_ij = -rho0 g_y (y_i - y_j) / c0^2 (h = d, walls at rest: v_b = 0).
//                The first two terms are the time derivative of the summation density
//                sum_j m W_ij + sum_b Psi_b W_ib (Akinci et al. 2012, eq. 6), so the two agree
//                wherever the kernel is full; the diffusive term is Molteni & Colagrossi's
//                ("A simple procedure to improve the pressure evaluation in hydrodynamic context
//                using the SPH", Comput. Phys. Commun. 180 (2009) 861-872) with the hydrostatic
//                density difference rho^H_ij taken out as in Fourtakas, Dominguez, Vacondio,
//                Rogers 2019 ("Local uniform stencil (LUST) boundary condition for arbitrary 3-D
//                boundaries in parallel SPH models", Comput. Fluids 190, 346-361; DualSPHysics'
//                DensityDT=2), linearised in rho0 g dy / B ~ 1e-3: a column at rest keeps its
//                hydrostatic density instead of diffusing it towards uniform, which Antuono et
//                al. 2010 (Comput. Phys. Commun. 181, 532-549) do with renormalised density
//                gradients at the cost of a matrix per particle. It runs over fluid pairs only
//                (DualSPHysics' DensityDT=2 likewise): the boundary particles carry no density
//                of their own. psi_ji = psi_ij, so the term is antisymmetric in the pair and
//                sum_i (m / rho_i) D_i = 0. delta = density_diffusion (0.1, the literature's);
//                0 leaves the plain continuity equation, whose pressure noise is left undamped
//                (docs/validation.md: the dam break's front 41% off at the quick resolution).
//                Why not the summation density (as before): with p clamped at 0, a collapsing
//                column whose particles have opened up by a few percent has no pressure at all,
//                and nothing closes it again; the dam break's residual column then drains 50%
//                too slowly by tau = 3.44 (docs/validation.md). The carried density remembers that
//                each particle holds a rest volume m / rho0, and a free surface's kernel deficit
//                no longer counts as expansion. It starts (InitialDensity: a new run, a reset, a
//                checkpoint without it, particles the solver did not start) at max(summation
//                density, rho0): rho0 on a spawned lattice, the summation density of a state
//                compressed by another solver. A checkpoint holds it (SaveArrays, "density").
//   Tait EOS     p_i = B ((rho_i / rho0)^gamma - 1), B = rho0 c0^2 / gamma, gamma = 7 (eq. 7),
//                clamped at 0: an expanding splash must not pull particles together
//   pressure     a_i = -[sum_j m (p_i / rho_i^2 + p_j / rho_j^2) grad W_ij          (eq. 6)
//                       + sum_b Psi_b (p_i / rho_i^2 + p_b / rho_b^2) grad W_ib] / mu
//                with mu the kernel's gradient moment on the rest lattice (1.020 at support
//                2 d, kernels.h), so that the discrete force of a linear pressure field is its
//                exact gradient: without it the tank settles 2% below rho g (H - y).
//                with the boundary particle's pressure extrapolated from the fluid around it,
//                p_b = sum_f (p_f + rho_f g . (x_b - x_f)) W_bf / sum_f W_bf (Adami, Hu, Adams
//                2012, "A generalized wall boundary condition for SPH", eq. 27), clamped at 0,
//                and rho_b from p_b by the inverse Tait equation. Akinci's mirrored pressure
//                (p_b = p_i) gives either a spurious push into the wall (Akinci's eq. 10,
//                p_i / rho_i^2 alone) or, symmetrised, a non-conservative force that made the
//                hydrostatic tank unstable; the extrapolated pressure carries the hydrostatic
//                gradient into the wall, which the tank needs to within 2%.
//   viscosity    a_i += 2 (dim + 2) nu sum_j (m / rho_j) (v_ij . x_ij) / (|x_ij|^2 + 0.01 h^2)
//                       grad W_ij: the laminar viscosity of Morris et al. 1997 in the form of
//                Monaghan 2005 (sec. 5.6), with a physical kinematic viscosity nu (m^2/s),
//                divided by lambda, the kernel's viscosity moment on the rest lattice (0.708
//                at support 2 d, kernels.h): without it the fluid's viscosity is 29% low.
//                Monaghan's artificial viscosity alpha (below) corresponds to nu = alpha h c0 /
//                (2 (dim + 2)). Walls are free-slip, except across the axes the scene marks
//                no-slip: there the same term runs over the wall's boundary particles,
//                a_i += 2 (dim + 2) nu sum_b V_b ((v_i - v_b) . x_ib) / (|x_ib|^2 + 0.01 h^2)
//                grad W_ib, with v_b = -sum_f v_f W_bf / sum_f W_bf, the fluid's velocity
//                extrapolated to b and mirrored, so that it falls to 0 at the wall surface
//                between them (Adami, Hu, Adams 2012, eqs. 22-23, for a wall at rest; Morris,
//                Fox, Zhu 1997 mirror the velocity the same way).
//   artificial   with alpha = artificial_viscosity > 0 (Monaghan 1992, "Smoothed particle
//   viscosity    hydrodynamics", Annu. Rev. Astron. Astrophys. 30, 543-574, as
//                DualSPHysics implements it), over the fluid pairs that approach, v_ij . x_ij < 0
//                (v_ij = v_i - v_j, x_ij = x_i - x_j):
//                a_i += -sum_j m Pi_ij grad W_ij,   Pi_ij = -alpha c0 mu_ij / rho_ij,
//                mu_ij = h (v_ij . x_ij) / (|x_ij|^2 + 0.01 h^2),  rho_ij = (rho_i + rho_j) / 2,
//                that is a_i += 2 alpha c0 h m sum_j (v_ij . x_ij) / ((rho_i + rho_j)
//                (|x_ij|^2 + 0.01 h^2)) grad W_ij, with c0 the scene's speed of sound, h the
//                smoothing length (support 2 h, as DualSPHysics's h) and the carried densities.
//                Pi_ji = Pi_ij and grad W_ji = -grad W_ij: a pair's two forces are opposite, so
//                momentum is conserved; a separating pair gets nothing. It is the laminar term
//                above with nu = alpha h c0 / (2 (dim + 2)) (rho_j / rho_ij of it, and not divided
//                by lambda: alpha is a numerical parameter, taken at the literature's values),
//                acting on approaching pairs only. It damps particle-scale velocity noise, which
//                the physical nu = 1e-6 m^2/s of water leaves undamped at fine resolution (the
//                dam break at a/120, docs/validation.md). At the no-slip walls
//                it runs over the wall's boundary particles exactly as the laminar wall term
//                does, with its mirrored velocity v_b and V_b for m_b / rho_ib (the laminar
//                term's m_b / rho_b): a_i += alpha c0 h sum_b V_b min(v_ib . x_ib, 0) /
//                (|x_ib|^2 + 0.01 h^2) grad W_ib. Free-slip walls and obstacles (moving ones
//                included) get none: they push with their pressure only, which is what free-slip
//                means here, and alpha must not change the walls the scene chose. (DualSPHysics's
//                boundary particles get it against their own velocity, 0 or the body's, which
//                makes every wall there a friction wall.) The sum over the fluid and the one over
//                the walls each have their own accumulator in the same sweep, added only when
//                alpha > 0: with alpha = 0 a step is bit for bit what it was without the term.
//                Its time step bound joins the viscous one (cfl_time_step.h).
//   contact      the boundary particles' pressure acts only where the fluid is compressed; a
//                thin splash or surge tip has a density below rho0 and no pressure, and would
//                sink through them. So no particle may come closer than r0 / 2 = 0.2 d to a
//                wall or an obstacle: the integration cuts a velocity towards the surface that
//                would take it nearer in the step (LimitApproachToSurfaces), an inelastic
//                contact. At rest the first fluid layer is d / 2 from a wall, out of reach.
//                (Monaghan's 1994 repulsive force, D [(r0 / r)^12 - (r0 / r)^4] / r within r0,
//                was used before: its stiffness, integrated explicitly, made a lone splash
//                particle gain energy at every bounce, to 214 m/s in the stress suite's block
//                at the default CFL factor after 1.4 s, and at a CFL factor of 0.4 and beyond
//                the bulk too: bench/stress_bench.)
//   gravity      g(t) = g (1 - cos(pi t / T)) / 2 for t < T, g after (ramp time T; 0: none)
//   integration  semi-implicit (symplectic) Euler, v += a dt; x += v dt; rho += (D rho / Dt) dt
//                (the rate of the step's start, like a), with the CFL step of
//                cfl_time_step.h; the speed of sound c0 >= 10 v_max keeps density variations
//                near 1% (Becker & Teschner, sec. 3.1; Monaghan 1994). time_integration = 1
//                takes DualSPHysics's second-order predictor-corrector instead (symplectic.h).
// Every neighbour loop gathers into the particle it is for, reading the state of the previous
// pass, so a step is bit-identical for any thread count. The positions are finally clamped to
// the domain (velocity into the wall removed) as a last resort only: the boundary particles and
// the contact force hold the fluid inside it (becker_teschner_solver_test checks that the clamp
// never acts in a dam break past obstacles).
#pragma once

#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "dysa/core/solver.h"
#include "solvers/physical/physical_data.h"

namespace dysa::wcsph {

// What wcsph keeps besides the shared State and the physical solvers' data; per step.
struct BeckerTeschnerData : physical::PhysicalData {
  // Pa, per boundary particle: the pressure extrapolated from the fluid around it, and
  // p_b / rho_b^2 (Pa m^6/kg^2), rho_b from p_b by the inverse Tait equation.
  std::vector<Real> boundary_pressure;
  std::vector<Real> boundary_p_over_rho2;
  // Pa m^6/kg^2, per particle: p_i / rho_i^2, which the pressure force reads of each neighbour.
  std::vector<Real> p_over_rho2;
  // kg/m^3, per particle in storage order: the density the continuity equation carries from
  // step to step (a checkpoint holds it: SaveArrays), permuted with the particles; empty or of
  // another size until InitialDensity.
  std::vector<Real> density;
  // kg/m^3/s, per particle: this step's D rho / Dt.
  std::vector<Real> density_rate;
  // The predictor-corrector's state at the step's start (symplectic.h), kept by `predict` and
  // permuted with the particles by the corrector's neighbour sort while `predicted`.
  struct StepStart {
    std::vector<Vec3> position;  // m
    std::vector<Vec3> velocity;  // m/s
    std::vector<Real> density;   // kg/m^3, the carried density
    double time = 0;             // s
    bool predicted = false;      // between `predict` and `correct`
  } step_start;
};

// The name of the carried density in a checkpoint (SolverArray::name).
inline constexpr std::string_view kCarriedDensity = "density";

// The carried density's range, as multiples of rho0: DualSPHysics's RhopOut limits (700 and
// 1300 kg/m^3 for water). The continuity equation is unbounded: a splash particle with a few
// neighbours flying apart can integrate its density through zero, and the density diffusion
// of each neighbour, which divides by rho_j, then jumps by orders of magnitude in one step (Test
// 2 at dp 0.02 reached 7,371 kg/m^3 next to a particle at -268, and the CFL step collapsed).
// DualSPHysics removes such particles; here they are held at the bound and stay in the flow. A
// flow within the weakly compressible regime (|rho / rho0 - 1| ~ 1%) never reaches either bound.
// The lower bound is the scene's `carried_density_min` (0.7 by default, over rho0).
inline constexpr double kCarriedDensityMax = 1.3;

// rho held within [lo, hi] (kg/m^3); the CUDA kernels compare in the same order.
inline Real BoundCarriedDensity(Real rho, Real lo, Real hi) {
  return rho < lo ? lo : (rho > hi ? hi : rho);
}

// alpha c0 h (m^2/s), the artificial viscosity's strength (0: off): ComputeInteractions scales
// its sum over the fluid by 2 alpha c0 h m and its sum over the no-slip walls by alpha c0 h; the
// CUDA backend takes the same floats from here.
inline double ArtificialViscosityStrength(const Model& model) {
  return model.params.artificial_viscosity * model.params.speed_of_sound * model.SmoothingLength();
}

class BeckerTeschnerSolver final : public Solver {
 public:
  // Samples the boundary particles (from the domain, the obstacles and the spacing) for the
  // passes of this list.
  std::vector<Pass> BuildPasses(const Model& model) override;
  // The carried density starts (InitialDensity) at the next step.
  void Reset(size_t particles) override;
  std::vector<SolverArray> SaveArrays() const override;
  void RestoreArrays(std::span<const SolverArray> arrays, size_t particles) override;
  std::vector<Vec3> BoundaryPositions() const override;
  const BeckerTeschnerData& data() const { return data_; }

 private:
  BeckerTeschnerData data_;
};

std::unique_ptr<Solver> CreateBeckerTeschnerSolver();

// The passes, exposed for tests; those it shares with dfsph (the neighbour sort, viscosity, the
// wall contact, gravity) are in solvers/physical/physical_passes.h.
// The neighbour sort, which also carries data.density along with the particles.
void SortIntoGrid(const Model& model, BeckerTeschnerData& data, State& state);
// data.density of every particle from the positions: max(summation density, rho0).
void InitialDensity(const Model& model, BeckerTeschnerData& data, State& state);
// The `pressure` pass: p.density, p.pressure (Tait) and data.p_over_rho2 from the carried
// density (InitialDensity first where it has another size than the particles). No neighbours.
void ComputePressure(const Model& model, BeckerTeschnerData& data, State& state);
// The `boundary_pressure` pass, over the boundary particles only: data.boundary_pressure and
// boundary_p_over_rho2, and with a viscosity (laminar or artificial) and a no-slip wall
// data.boundary_velocity (physical::ExtrapolateWallVelocity).
void ComputeBoundaryPressure(const Model& model, BeckerTeschnerData& data, State& state);
// The `interactions` pass, the step's one sweep over each particle's neighbours: everything it
// needs is the state of the step's start and the two passes above, so the continuity
// equation's data.density_rate, the pressure force, the viscosity, the no-slip walls'
// viscosity and the artificial viscosity (fluid and no-slip walls) are summed in the same sweep,
// each in its own accumulator in the grid's order (the same bits as when each had its own pass);
// data.acceleration = gravity + all of them.
void ComputeInteractions(const Model& model, BeckerTeschnerData& data, State& state);
// v += a dt, the wall contact (physical::LimitApproachToSurfaces), x += v dt (plus the particle
// shifting's data.shift dt where it is on), the last-resort clamp, rho += (D rho / Dt) dt.
void Integrate(const Model& model, BeckerTeschnerData& data, State& state);

}  // namespace dysa::wcsph
