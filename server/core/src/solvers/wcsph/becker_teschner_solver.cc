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

using physical::AddViscosity;
using physical::AddWallViscosity;
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

void ComputeDensityAndPressure(const Model& model, BeckerTeschnerData& data, State& state) {
  if (data.density.size() != state.particles.size()) InitialDensity(model, data, state);
  const BoundaryParticles& boundary = *data.boundary;
  ParticleArrays& p = state.particles;
  const PhysicalKernel<Real> kernel = model.Kernel();
  const Real support = kernel.support;
  const Real mass = Real(model.particle_mass);
  const double rho0 = model.params.rest_density;
  const double c0 = model.params.speed_of_sound;
  const Real psi_scale = Real(rho0);                        // Psi_b = rho0 V_b
  const double stiffness = rho0 * c0 * c0 / kTaitExponent;  // B = rho0 c0^2 / gamma
  // delta h c0 of the diffusive term (the support is 2 h)
  const Real diffusion = Real(model.params.density_diffusion * model.SmoothingLength() * c0);
  // rho^H_ij = -rho0 g_y y_ij / c0^2: the hydrostatic density difference rho_j - rho_i
  const Real hydrostatic = Real(-rho0 * GravityAt(model.params, state.time) / (c0 * c0));
  const Real* rho = data.density.data();
  const Real* volume = boundary.padded_volume();
  const Vec3* boundary_velocity =
      boundary.HasMovingObstacles() ? boundary.velocity().data() : nullptr;
  const int64_t n = int64_t(p.size());
  data.density_rate.resize(p.size());
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    const Eigen::Vector3i cell = state.grid.SortedCell(uint32_t(i));
    const Vec3& x = p.position[i];
    const Vec3& v = p.velocity[i];
    const Real rho_i = rho[i];
    Real divergence = 0;  // sum_j m (v_i - v_j) . grad W_ij
    Real diffused = 0;    // sum_j (rho_j - rho_i - rho^H_ij) (x_ji . grad W_ij) / r^2 / rho_j
    ForEachWithin(state.grid, cell, x, support, [&](uint32_t j, const Vec3& xij, Real r) {
      if (r <= 0) return;
      const Vec3 grad = GradW(xij, r, kernel);
      divergence += (v - p.velocity[j]).dot(grad);
      const Real dynamic = rho[j] - rho_i - hydrostatic * xij.y();
      diffused += dynamic * (-xij.dot(grad)) / (r * r * rho[j]);
    });
    Real wall = 0;  // sum_b V_b (v_i - v_b) . grad W_ib, v_b = 0 but on moving obstacles
    if (boundary_velocity == nullptr) {
      ForEachWithin(boundary.grid(), cell, x, support, [&](uint32_t b, const Vec3& xib, Real r) {
        wall += volume[b] * v.dot(GradW(xib, r, kernel));
      });
    } else {
      ForEachWithin(boundary.grid(), cell, x, support, [&](uint32_t b, const Vec3& xib, Real r) {
        wall += volume[b] * (v - boundary_velocity[b]).dot(GradW(xib, r, kernel));
      });
    }
    data.density_rate[i] = mass * divergence + psi_scale * wall + 2 * diffusion * mass * diffused;
    p.density[i] = rho_i;
    // In double: (rho / rho0)^7 - 1 of a 0.1% compression is 7e-3, which float would round to
    // a few digits.
    const double ratio = double(rho_i) / rho0;
    const double pressure = stiffness * (std::pow(ratio, kTaitExponent) - 1);
    p.pressure[i] = Real(pressure > 0 ? pressure : 0);
  }
}

void ComputeBoundaryPressure(const Model& model, BeckerTeschnerData& data, State& state) {
  const BoundaryParticles& boundary = *data.boundary;
  const ParticleArrays& p = state.particles;
  const PhysicalKernel<Real> kernel = model.Kernel();
  const Real support = kernel.support;
  const Vec3 gravity(0, Real(GravityAt(model.params, state.time)), 0);
  const NeighborGrid& bgrid = boundary.grid();
  const Real* bx = bgrid.xs().data();
  const Real* by = bgrid.ys().data();
  const Real* bz = bgrid.zs().data();
  const int64_t n = int64_t(boundary.size());
  data.boundary_pressure.resize(boundary.size());
#pragma omp parallel for schedule(static)
  for (int64_t b = 0; b < n; ++b) {
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
  }
}

void ComputePressureAcceleration(const Model& model, BeckerTeschnerData& data, State& state) {
  const BoundaryParticles& boundary = *data.boundary;
  ParticleArrays& p = state.particles;
  const PhysicalKernel<Real> kernel = model.Kernel();
  const Real support = kernel.support;
  const Real mass = Real(model.particle_mass);
  const double rho0 = model.params.rest_density;
  const Real psi_scale = Real(rho0);
  const Real gradient_scale = Real(1 / model.gradient_moment);
  const double stiffness =
      rho0 * model.params.speed_of_sound * model.params.speed_of_sound / kTaitExponent;
  const Vec3 gravity(0, Real(GravityAt(model.params, state.time)), 0);
  const Real* volume = boundary.padded_volume();
  const size_t n = p.size();
  const size_t nb = boundary.size();
  data.acceleration.resize(n);
  // p_j / rho_j^2 of every fluid particle, then of every boundary particle (its density from
  // its pressure through the inverse Tait equation), read by the neighbours.
  state.real_scratch.resize(n + nb);
  Real* p_over_rho2 = state.real_scratch.data();
  Real* boundary_p_over_rho2 = p_over_rho2 + n;
#pragma omp parallel for schedule(static)
  for (int64_t j = 0; j < int64_t(n); ++j) {
    p_over_rho2[j] = p.pressure[j] / (p.density[j] * p.density[j]);
  }
#pragma omp parallel for schedule(static)
  for (int64_t b = 0; b < int64_t(nb); ++b) {
    const double pb = data.boundary_pressure[b];
    const double rho = rho0 * std::pow(pb / stiffness + 1, 1 / kTaitExponent);
    boundary_p_over_rho2[b] = Real(pb / (rho * rho));
  }
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < int64_t(n); ++i) {
    const Eigen::Vector3i cell = state.grid.SortedCell(uint32_t(i));
    const Vec3& x = p.position[i];
    const Real pi = p_over_rho2[i];
    Vec3 fluid = Vec3::Zero();  // sum_j (p_i / rho_i^2 + p_j / rho_j^2) grad W_ij
    ForEachWithin(state.grid, cell, x, support, [&](uint32_t j, const Vec3& xij, Real r) {
      fluid += (pi + p_over_rho2[j]) * GradW(xij, r, kernel);
    });
    Vec3 wall = Vec3::Zero();  // sum_b V_b (p_i / rho_i^2 + p_b / rho_b^2) grad W_ib
    ForEachWithin(boundary.grid(), cell, x, support, [&](uint32_t b, const Vec3& xib, Real r) {
      wall += (volume[b] * (pi + boundary_p_over_rho2[b])) * GradW(xib, r, kernel);
    });
    data.acceleration[i] = gravity - gradient_scale * (mass * fluid + psi_scale * wall);
  }
}

void Integrate(const Model& model, BeckerTeschnerData& data, State& state) {
  ParticleArrays& p = state.particles;
  const Real dt = Real(state.dt);
  const int64_t n = int64_t(p.size());
  const std::vector<physical::ObstacleFrame> frames =
      physical::ObstacleFramesOverStep(model, state.time, state.dt);
  const Vec3* shift = model.params.particle_shifting > 0 ? data.shift.data() : nullptr;
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
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
    data.density[i] += data.density_rate[i] * dt;
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

std::vector<Pass> BeckerTeschnerSolver::BuildPasses(const Model& model) {
  data_.SampleBoundary(model);
  std::vector<Pass> passes;
  if (data_.boundary->HasMovingObstacles()) {
    passes.push_back(SolverPass("move_boundary", data_, physical::MoveBoundary));
  }
  passes.push_back(SolverPass("neighbour_grid", data_, SortIntoGrid));
  passes.push_back(SolverPass("density", data_, ComputeDensityAndPressure));
  passes.push_back(SolverPass("boundary_pressure", data_, ComputeBoundaryPressure));
  passes.push_back(SolverPass("pressure_force", data_, ComputePressureAcceleration));
  if (model.params.kinematic_viscosity > 0) {
    passes.push_back(SolverPass("viscosity", data_, AddViscosity));
    if (data_.boundary->HasNoSlip()) {
      passes.push_back(SolverPass("wall_viscosity", data_, AddWallViscosity));
    }
  }
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
