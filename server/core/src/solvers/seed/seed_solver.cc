#include "solvers/seed/seed_solver.h"

#include <cmath>
#include <cstdint>

#include "common_passes.h"
#include "dysa/core/kernels.h"

namespace dysa::seed {
namespace {

// A unit direction for two coincident particles: the pair (i, j) gets a direction from a hash
// of their ids, and (j, i) the opposite one, so the pair still exerts equal and opposite forces
// and a cluster of coincident particles spreads in 3D instead of moving together.
Vec3 CoincidentDirection(uint32_t id_i, uint32_t id_j) {
  const uint32_t lo = id_i < id_j ? id_i : id_j;
  const uint32_t hi = id_i < id_j ? id_j : id_i;
  uint64_t h = (uint64_t{lo} << 32 | hi) * 0x9E3779B97F4A7C15ull;
  h ^= h >> 29;
  h *= 0xBF58476D1CE4E5B9ull;
  h ^= h >> 32;
  Vec3 d(Real(int(h & 0xFFFF)) - Real(32767.5), Real(int((h >> 16) & 0xFFFF)) - Real(32767.5),
         Real(int((h >> 32) & 0xFFFF)) - Real(32767.5));
  d.normalize();
  return id_i < id_j ? d : Vec3(-d);
}

}  // namespace

void ApplyExternalForces(const Model& model, State& state) {
  ParticleArrays& p = state.particles;
  const Vec3 dv(0, Real(model.params.gravity * model.dt), 0);
  const int64_t n = static_cast<int64_t>(p.size());
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    p.velocity[i] += dv;
    p.predicted[i] = p.position[i] + p.velocity[i] * kPredictionLookahead;
  }
}

template <bool kNear>
void ComputeDensities(const Model& model, State& state) {
  ParticleArrays& p = state.particles;
  const SeedKernelFactors<Real> k(Real(model.params.smoothing_radius));
  const Real mass = Real(model.params.particle_mass);
  const Real rho0 = Real(model.params.target_density);
  const Real stiffness = Real(model.params.pressure_multiplier);
  const Real near_stiffness = Real(model.params.near_pressure_multiplier);
  const Vec3* x = p.predicted.data();
  const NeighborGrid& grid = state.grid;
  const int64_t n = static_cast<int64_t>(p.size());
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    const Vec3 xi = x[i];
    Real sum2 = 0;  // sum of (h - r)^2
    Real sum3 = 0;  // sum of (h - r)^3
    grid.ForEachNeighborRun(grid.SortedCell(uint32_t(i)), [&](uint32_t begin, uint32_t end) {
      for (uint32_t j = begin; j < end; ++j) {
        const Real r2 = (x[j] - xi).squaredNorm();
        if (r2 >= k.h2) continue;
        const Real q = k.h - std::sqrt(r2);
        sum2 += q * q;
        if constexpr (kNear) sum3 += q * q * q;
      }
    });
    const Real rho = mass * k.spiky2 * sum2;
    p.density[i] = rho;
    p.pressure[i] = (rho - rho0) * stiffness;
    if constexpr (kNear) {
      const Real rho_near = mass * k.spiky3 * sum3;
      p.near_density[i] = rho_near;
      p.near_pressure[i] = rho_near * near_stiffness;
    }
  }
}

// a_i = m / rho_i * sum_j dW(r_ij)/dr * (p_i + p_j) / 2 / rho_j * (x_j - x_i) / r_ij, plus the
// same with the near density, near pressure and the spiky^3 gradient.
template <bool kNear>
void ApplyPressureForces(const Model& model, State& state) {
  ParticleArrays& p = state.particles;
  const SeedKernelFactors<Real> k(Real(model.params.smoothing_radius));
  const Real mass_dt = Real(model.params.particle_mass * model.dt);
  const Vec3* x = p.predicted.data();
  const Real* rho = p.density.data();
  const Real* pressure = p.pressure.data();
  const Real* rho_near = p.near_density.data();
  const Real* near_pressure = p.near_pressure.data();
  const uint32_t* id = p.id.data();
  const NeighborGrid& grid = state.grid;
  const int64_t n = static_cast<int64_t>(p.size());
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    const Vec3 xi = x[i];
    const Real pi = pressure[i];
    const Real pni = kNear ? near_pressure[i] : Real(0);
    Vec3 force = Vec3::Zero();
    grid.ForEachNeighborRun(grid.SortedCell(uint32_t(i)), [&](uint32_t begin, uint32_t end) {
      for (uint32_t j = begin; j < end; ++j) {
        const Vec3 d = x[j] - xi;
        const Real r2 = d.squaredNorm();
        if (r2 >= k.h2 || j == uint32_t(i)) continue;
        const Real r = std::sqrt(r2);
        const Vec3 dir = r > 0 ? Vec3(d / r) : CoincidentDirection(id[i], id[j]);
        const Real q = k.h - r;
        // -dW/dr; the minus sign of the gradient is folded into the subtraction below.
        Real magnitude = k.spiky2_grad * q * Real(0.5) * (pi + pressure[j]) / rho[j];
        if constexpr (kNear) {
          magnitude += k.spiky3_grad * q * q * Real(0.5) * (pni + near_pressure[j]) / rho_near[j];
        }
        force -= dir * magnitude;
      }
    });
    p.velocity[i] += force * (mass_dt / rho[i]);
  }
}

// v_i += mu dt sum_j (v_j - v_i) W_poly6(r_ij), reading the velocities before the pass and
// writing a second buffer, so the result does not depend on the order particles are visited.
void ApplyViscosity(const Model& model, State& state) {
  ParticleArrays& p = state.particles;
  const SeedKernelFactors<Real> k(Real(model.params.smoothing_radius));
  const Real scale = Real(model.params.viscosity * model.dt) * k.poly6;
  const Vec3* x = p.predicted.data();
  const Vec3* v = p.velocity.data();
  state.vec3_scratch.resize(p.size());
  Vec3* v_out = state.vec3_scratch.data();
  const NeighborGrid& grid = state.grid;
  const int64_t n = static_cast<int64_t>(p.size());
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    const Vec3 xi = x[i];
    const Vec3 vi = v[i];
    Vec3 sum = Vec3::Zero();
    grid.ForEachNeighborRun(grid.SortedCell(uint32_t(i)), [&](uint32_t begin, uint32_t end) {
      for (uint32_t j = begin; j < end; ++j) {
        const Real r2 = (x[j] - xi).squaredNorm();
        if (r2 >= k.h2) continue;
        const Real w = k.h2 - r2;
        sum += (v[j] - vi) * (w * w * w);
      }
    });
    v_out[i] = vi + sum * scale;
  }
  p.velocity.swap(state.vec3_scratch);
}

void IntegrateAndCollideWithWalls(const Model& model, State& state) {
  ParticleArrays& p = state.particles;
  const Real dt = Real(model.dt);
  const Real damping = Real(model.params.collision_damping);
  const int64_t n = static_cast<int64_t>(p.size());
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    p.position[i] += p.velocity[i] * dt;
    CollideWithDomainWalls(model.domain, damping, p.position[i], p.velocity[i]);
  }
}

template void ComputeDensities<true>(const Model&, State&);
template void ComputeDensities<false>(const Model&, State&);
template void ApplyPressureForces<true>(const Model&, State&);
template void ApplyPressureForces<false>(const Model&, State&);

std::vector<Pass> SeedSolver::BuildPasses(const Model& model) const {
  const bool near = model.params.near_pressure_multiplier > 0;
  std::vector<Pass> passes;
  passes.push_back({"external_forces", ApplyExternalForces});
  passes.push_back({"neighbour_grid", SortParticlesIntoGrid});
  if (near) {
    passes.push_back({"density", ComputeDensities<true>});
    passes.push_back({"pressure_force", ApplyPressureForces<true>});
  } else {
    passes.push_back({"density", ComputeDensities<false>});
    passes.push_back({"pressure_force", ApplyPressureForces<false>});
  }
  if (model.params.viscosity > 0) passes.push_back({"viscosity", ApplyViscosity});
  passes.push_back({"integrate", IntegrateAndCollideWithWalls});
  if (model.HasObstacles()) passes.push_back({"obstacles", CollideWithObstacles});
  return passes;
}

std::unique_ptr<Solver> CreateSeedSolver() { return std::make_unique<SeedSolver>(); }

}  // namespace dysa::seed
