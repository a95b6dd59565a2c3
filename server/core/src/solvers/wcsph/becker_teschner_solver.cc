#include "solvers/wcsph/becker_teschner_solver.h"

#include <cmath>
#include <cstdint>
#include <string>

#include "dysa/core/kernels.h"
#include "solvers/domain_walls.h"
#include "solvers/physical/cfl_time_step.h"
#include "solvers/physical/particle_shifting.h"
#include "solvers/physical/physical_passes.h"
#include "solvers/wcsph/symplectic.h"
#include "sph_loops.h"

namespace dysa::wcsph {

using physical::GravityAt;
using physical::kTaitExponent;

void SortIntoGrid(const Model& model, BeckerTeschnerData& data, State& state) {
  physical::SortIntoGrid(model, state);
  // The carried density moves with its particle; one of another size (particles the solver did
  // not start) is left for InitialDensity.
  if (data.density.size() == state.particles.size()) {
    PermuteInPlace(state.grid.order(), data.density, state.real_scratch);
  }
  // Between predict and correct (symplectic.h) the step's start moves with its particle too.
  if (data.step_start.predicted) {
    BeckerTeschnerData::StepStart& start = data.step_start;
    PermuteInPlace(state.grid.order(), start.position, state.vec3_scratch);
    PermuteInPlace(state.grid.order(), start.velocity, state.vec3_scratch);
    PermuteInPlace(state.grid.order(), start.density, state.real_scratch);
  }
}

void InitialDensity(const Model& model, BeckerTeschnerData& data, State& state) {
  const BoundaryParticles& boundary = *data.boundary;
  const ParticleArrays& p = state.particles;
  const PhysicalKernel<Real> kernel = model.Kernel();
  const Real support = kernel.support;
  const Real mass = Real(model.particle_mass);
  const Real rho0 = Real(model.params.rest_density);
  const Real psi_scale = rho0;  // Psi_b = rho0 V_b
  const Real density_scale = Real(1 / model.density_moment);
  const Real* volume = boundary.padded_volume();
  const int64_t n = int64_t(p.size());
  data.density.resize(p.size());
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    const Eigen::Vector3i cell = state.grid.SortedCell(uint32_t(i));
    const Vec3& x = p.position[i];
    Real fluid = 0;
    ForEachWithin(state.grid, cell, x, support,
                  [&](uint32_t, const Vec3&, Real r) { fluid += kernel.W(r); });
    Real wall = 0;
    ForEachWithin(boundary.grid(), cell, x, support,
                  [&](uint32_t b, const Vec3&, Real r) { wall += volume[b] * kernel.W(r); });
    const Real rho = (mass * fluid + psi_scale * wall) * density_scale;
    data.density[i] = rho > rho0 ? rho : rho0;
  }
}

void ComputePressure(const Model& model, BeckerTeschnerData& data, State& state) {
  if (data.density.size() != state.particles.size()) InitialDensity(model, data, state);
  ParticleArrays& p = state.particles;
  const double rho0 = model.params.rest_density;
  const double c0 = model.params.speed_of_sound;
  const double stiffness = rho0 * c0 * c0 / kTaitExponent;  // B = rho0 c0^2 / gamma
  const int64_t n = int64_t(p.size());
  data.p_over_rho2.resize(p.size());
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    const Real rho = data.density[i];
    p.density[i] = rho;
    // In double: (rho / rho0)^7 - 1 of a 0.1% compression is 7e-3, which float would round to
    // a few digits.
    const double pressure = stiffness * (std::pow(double(rho) / rho0, kTaitExponent) - 1);
    p.pressure[i] = Real(pressure > 0 ? pressure : 0);
    data.p_over_rho2[i] = p.pressure[i] / (p.density[i] * p.density[i]);
  }
}

void ComputeBoundaryPressure(const Model& model, BeckerTeschnerData& data, State& state) {
  const BoundaryParticles& boundary = *data.boundary;
  const ParticleArrays& p = state.particles;
  const PhysicalKernel<Real> kernel = model.Kernel();
  const Real support = kernel.support;
  const double rho0 = model.params.rest_density;
  const double stiffness =
      rho0 * model.params.speed_of_sound * model.params.speed_of_sound / kTaitExponent;
  const Vec3 gravity(0, Real(GravityAt(model.params, state.time)), 0);
  const NeighborGrid& bgrid = boundary.grid();
  const Real* bx = bgrid.xs().data();
  const Real* by = bgrid.ys().data();
  const Real* bz = bgrid.zs().data();
  const int64_t n = int64_t(boundary.size());
  data.boundary_pressure.resize(boundary.size());
  data.boundary_p_over_rho2.resize(boundary.size());
  const ProcessShare& share = state.share;
#pragma omp parallel for schedule(static)
  for (int64_t b = 0; b < n; ++b) {
    // Across processes, only the boundary particles this process's own particles read.
    if (!share.NeedsBoundaryCell(bgrid.SortedCell(uint32_t(b)))) continue;
    const Vec3 x(bx[b], by[b], bz[b]);
    Real weights = 0;
    Real weighted = 0;  // sum_f (p_f + rho_f g . (x_b - x_f)) W_bf
    // The boundary grid's cell of b is a cell of the fluid grid too (same layout).
    ForEachWithin(state.grid, bgrid.SortedCell(uint32_t(b)), x, support,
                  [&](uint32_t f, const Vec3& xbf, Real r) {
                    const Real w = kernel.W(r);
                    weights += w;
                    weighted += (p.pressure[f] + p.density[f] * gravity.dot(xbf)) * w;
                  });
    const Real pressure = weights > 0 ? weighted / weights : Real(0);
    data.boundary_pressure[b] = pressure > 0 ? pressure : Real(0);
    // p_b / rho_b^2, rho_b from p_b by the inverse Tait equation; 0 without pressure (rho_b =
    // rho0 exactly, what pow would give, without its cost on every dry wall particle).
    if (data.boundary_pressure[b] == 0) {
      data.boundary_p_over_rho2[b] = 0;
      continue;
    }
    const double pb = data.boundary_pressure[b];
    const double rho = rho0 * std::pow(pb / stiffness + 1, 1 / kTaitExponent);
    data.boundary_p_over_rho2[b] = Real(pb / (rho * rho));
  }
  // The no-slip walls' mirrored velocity, which the laminar and the artificial viscosity read.
  const bool viscous =
      model.params.kinematic_viscosity > 0 || model.params.artificial_viscosity > 0;
  if (viscous && boundary.HasNoSlip()) {
    physical::ExtrapolateWallVelocity(model, data, state);
  }
}

namespace {

// The interactions' constants, read once per pass.
struct InteractionConstants {
  Real support, mass, psi_scale, gradient_scale, diffusion, hydrostatic;
  Real eps, viscosity_scale, wall_viscosity_scale, artificial_scale, wall_artificial_scale;
  bool viscosity, wall_viscosity, artificial, wall_artificial;
  Vec3 gravity;
};

}  // namespace

void ComputeInteractions(const Model& model, BeckerTeschnerData& data, State& state) {
  const BoundaryParticles& boundary = *data.boundary;
  ParticleArrays& p = state.particles;
  const PhysicalKernel<Real> kernel = model.Kernel();
  const double rho0 = model.params.rest_density;
  const double c0 = model.params.speed_of_sound;
  const double nu = model.params.kinematic_viscosity;
  const Real h = Real(model.SmoothingLength());
  InteractionConstants k;
  k.support = kernel.support;
  k.mass = Real(model.particle_mass);
  k.psi_scale = Real(rho0);  // Psi_b = rho0 V_b
  k.gradient_scale = Real(1 / model.gradient_moment);
  // delta h c0 of the diffusive term (the support is 2 h)
  k.diffusion = Real(model.params.density_diffusion * model.SmoothingLength() * c0);
  // rho^H_ij = -rho0 g_y y_ij / c0^2: the hydrostatic density difference rho_j - rho_i
  k.hydrostatic = Real(-rho0 * GravityAt(model.params, state.time) / (c0 * c0));
  k.eps = Real(0.01) * h * h;
  // 2 (dim + 2) nu m / lambda and 2 (dim + 2) nu / lambda, lambda the lattice's viscosity
  // moment (kernels.h)
  k.viscosity_scale = Real(10 * nu * model.particle_mass / model.viscosity_moment);
  k.wall_viscosity_scale = Real(10 * nu / model.viscosity_moment);
  k.viscosity = nu > 0;
  k.wall_viscosity = k.viscosity && boundary.HasNoSlip();
  // The artificial viscosity's 2 alpha c0 h m (fluid pairs: m / rho_ij = 2 m / (rho_i + rho_j))
  // and alpha c0 h (no-slip walls: V_b for m_b / rho_ib), becker_teschner_solver.h.
  const double alpha_c0_h = ArtificialViscosityStrength(model);
  k.artificial_scale = Real(2 * alpha_c0_h * model.particle_mass);
  k.wall_artificial_scale = Real(alpha_c0_h);
  k.artificial = alpha_c0_h > 0;
  k.wall_artificial = k.artificial && boundary.HasNoSlip();
  k.gravity = Vec3(0, Real(GravityAt(model.params, state.time)), 0);
  const Real* rho = data.density.data();
  const Real* p_over_rho2 = data.p_over_rho2.data();
  const Real* boundary_p_over_rho2 = data.boundary_p_over_rho2.data();
  const Real* volume = boundary.padded_volume();
  const std::span<const uint8_t> no_slip = boundary.no_slip();
  const Vec3* sample_velocity =
      boundary.HasMovingObstacles() ? boundary.velocity().data() : nullptr;
  const Vec3* wall_velocity = data.boundary_velocity.data();
  const int64_t n = int64_t(p.size());
  data.density_rate.resize(p.size());
  data.acceleration.resize(p.size());
  // A ghost's rates are read by no one (ProcessShare) unless within rate_reach: left as they
  // were.
  const ProcessShare& share = state.share;
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    if (share.SkipsRates(size_t(i))) continue;
    const Eigen::Vector3i cell = state.grid.SortedCell(uint32_t(i));
    const Vec3& x = p.position[i];
    const Vec3& v = p.velocity[i];
    const Real rho_i = rho[i];
    const Real pi = p_over_rho2[i];
    // Each sum keeps its own accumulator and the grid's order, as when each had its own pass.
    Real divergence = 0;        // sum_j m (v_i - v_j) . grad W_ij / m
    Real diffused = 0;          // sum_j (rho_j - rho_i - rho^H_ij) (x_ji . grad W_ij) / r^2 / rho_j
    Vec3 fluid = Vec3::Zero();  // sum_j (p_i / rho_i^2 + p_j / rho_j^2) grad W_ij
    Vec3 viscous = Vec3::Zero();  // sum_j (v_ij . x_ij) / (rho_j (r^2 + eps)) grad W_ij
    // sum_j min(v_ij . x_ij, 0) / ((rho_i + rho_j) (r^2 + eps)) grad W_ij: approaching pairs only
    Vec3 artificial = Vec3::Zero();
    ForEachWithin(state.grid, cell, x, k.support, [&](uint32_t j, const Vec3& xij, Real r) {
      const Vec3 grad = GradW(xij, r, kernel);
      fluid += (pi + p_over_rho2[j]) * grad;
      if (r <= 0) return;
      divergence += (v - p.velocity[j]).dot(grad);
      const Real dynamic = rho[j] - rho_i - k.hydrostatic * xij.y();
      diffused += dynamic * (-xij.dot(grad)) / (r * r * rho[j]);
      if (k.viscosity) {
        const Real vx = (v - p.velocity[j]).dot(xij);
        viscous += (vx / (p.density[j] * (r * r + k.eps))) * grad;
      }
      if (k.artificial) {
        const Real vx = (v - p.velocity[j]).dot(xij);
        if (vx < 0) artificial += (vx / ((rho_i + rho[j]) * (r * r + k.eps))) * grad;
      }
    });
    Real wall = 0;                     // sum_b V_b (v_i - v_b) . grad W_ib, v_b = 0 unless moving
    Vec3 wall_force = Vec3::Zero();    // sum_b V_b (p_i / rho_i^2 + p_b / rho_b^2) grad W_ib
    Vec3 wall_viscous = Vec3::Zero();  // sum_b V_b ((v_i - v_b) . x_ib) / (r^2 + eps) grad W_ib
    // sum_b V_b min((v_i - v_b) . x_ib, 0) / (r^2 + eps) grad W_ib, over the no-slip walls
    Vec3 wall_artificial = Vec3::Zero();
    ForEachWithin(boundary.grid(), cell, x, k.support, [&](uint32_t b, const Vec3& xib, Real r) {
      const Vec3 grad = GradW(xib, r, kernel);
      wall += volume[b] * (sample_velocity ? Vec3(v - sample_velocity[b]) : v).dot(grad);
      wall_force += (volume[b] * (pi + boundary_p_over_rho2[b])) * grad;
      if (k.wall_viscosity && no_slip[b] && r > 0) {
        const Real vx = (v - wall_velocity[b]).dot(xib);
        wall_viscous += (volume[b] * vx / (r * r + k.eps)) * grad;
      }
      if (k.wall_artificial && no_slip[b] && r > 0) {
        const Real vx = (v - wall_velocity[b]).dot(xib);
        if (vx < 0) wall_artificial += (volume[b] * vx / (r * r + k.eps)) * grad;
      }
    });
    data.density_rate[i] =
        k.mass * divergence + k.psi_scale * wall + 2 * k.diffusion * k.mass * diffused;
    Vec3 a = k.gravity - k.gradient_scale * (k.mass * fluid + k.psi_scale * wall_force);
    if (k.viscosity) a += k.viscosity_scale * viscous;
    if (k.wall_viscosity) a += k.wall_viscosity_scale * wall_viscous;
    // Only with alpha > 0: with alpha = 0 the step is bit for bit what it was without the term.
    if (k.artificial) a += k.artificial_scale * artificial;
    if (k.wall_artificial) a += k.wall_artificial_scale * wall_artificial;
    data.acceleration[i] = a;
  }
}

void Integrate(const Model& model, BeckerTeschnerData& data, State& state) {
  ParticleArrays& p = state.particles;
  const Real dt = Real(state.dt);
  const int64_t n = int64_t(p.size());
  const std::vector<physical::ObstacleFrame> frames =
      physical::ObstacleFramesOverStep(model, state.time, state.dt);
  const Vec3* shift = model.params.particle_shifting > 0 ? data.shift.data() : nullptr;
  const Real rho_lo = Real(model.params.rest_density * model.params.carried_density_min);
  const Real rho_hi = Real(model.params.rest_density * kCarriedDensityMax);
  // Ghosts are dropped after the step (ProcessShare) and their rates were not computed.
  const uint8_t* ghost = state.share.ghost.empty() ? nullptr : state.share.ghost.data();
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    if (ghost && ghost[i]) continue;
    p.velocity[i] += data.acceleration[i] * dt;
    physical::LimitApproachToSurfaces(model, frames, dt, p.position[i], p.velocity[i]);
    if (shift == nullptr) {
      p.position[i] += p.velocity[i] * dt;
    } else {
      // The shift's displacement too, cut by the contact as the velocity's.
      Vec3 drift = p.velocity[i] + shift[i];
      physical::LimitApproachToSurfaces(model, frames, dt, p.position[i], drift);
      p.position[i] += drift * dt;
    }
    CollideWithDomainWalls(model.domain, model.periodic, Real(0), p.position[i], p.velocity[i]);
    data.density[i] =
        BoundCarriedDensity(data.density[i] + data.density_rate[i] * dt, rho_lo, rho_hi);
    p.density[i] = data.density[i];
  }
}

void BeckerTeschnerSolver::Reset(size_t particles) {
  (void)particles;
  data_.density.clear();  // InitialDensity at the next step, from the positions
  data_.step_start.predicted = false;
}

std::vector<SolverArray> BeckerTeschnerSolver::SaveArrays() const {
  return {{std::string(kCarriedDensity), data_.density}};
}

void BeckerTeschnerSolver::RestoreArrays(std::span<const SolverArray> arrays, size_t particles) {
  Reset(particles);
  if (const auto* saved = FindSolverArray(arrays, kCarriedDensity, particles)) {
    data_.density = *saved;
  }
}

std::vector<Vec3> BeckerTeschnerSolver::BoundaryPositions() const {
  std::vector<Vec3> positions;
  if (!data_.boundary) return positions;
  const NeighborGrid& grid = data_.boundary->grid();
  positions.reserve(data_.boundary->size());
  for (size_t b = 0; b < data_.boundary->size(); ++b) {
    positions.emplace_back(grid.xs()[b], grid.ys()[b], grid.zs()[b]);
  }
  return positions;
}

std::vector<Pass> BeckerTeschnerSolver::BuildPasses(const Model& model) {
  data_.SampleBoundary(model);
  std::vector<Pass> passes;
  if (data_.boundary->HasMovingObstacles()) {
    passes.push_back(SolverPass("move_boundary", data_, physical::MoveBoundary));
  }
  passes.push_back(SolverPass("neighbour_grid", data_, SortIntoGrid));
  passes.push_back(SolverPass("pressure", data_, ComputePressure));
  passes.push_back(SolverPass("boundary_pressure", data_, ComputeBoundaryPressure));
  passes.push_back(SolverPass("interactions", data_, ComputeInteractions));
  const size_t forces_end = passes.size();
  passes.push_back(SolverPass("time_step", data_, ChooseTimeStepPass));
  if (model.params.time_integration == 1) {
    // The predictor-corrector: the force passes again at t + dt/2, under names of their own.
    passes.push_back(SolverPass("predict", data_, PredictHalfStep));
    for (size_t k = 0; k < forces_end; ++k) {
      Pass corrector = passes[k];
      corrector.name += kCorrectorSuffix;
      passes.push_back(std::move(corrector));
    }
  }
  if (model.params.particle_shifting > 0) {
    passes.push_back(SolverPass("shifting", data_, physical::ComputeParticleShifting));
  }
  if (model.params.time_integration == 1) {
    passes.push_back(SolverPass("correct", data_, CorrectStep));
  } else {
    passes.push_back(SolverPass("integrate", data_, Integrate));
  }
  return passes;
}

std::unique_ptr<Solver> CreateBeckerTeschnerSolver() {
  return std::make_unique<BeckerTeschnerSolver>();
}

}  // namespace dysa::wcsph
