#include "solvers/physical/particle_shifting.h"

#include <cstdint>

#include "dysa/core/kernels.h"
#include "sph_loops.h"

namespace dysa::physical {

void ComputeParticleShifting(const Model& model, PhysicalData& data, State& state) {
  const BoundaryParticles& boundary = *data.boundary;
  const ParticleArrays& p = state.particles;
  const PhysicalKernel<Real> kernel = model.Kernel();
  const Real support = kernel.support;
  const Real mass = Real(model.particle_mass);
  const Real coefficient = Real(model.params.particle_shifting * model.SmoothingLength());  // A h
  const Real free_surface = Real(kFreeSurfaceDivergence);
  const Real* volume = boundary.padded_volume();
  const int64_t n = int64_t(p.size());
  data.shift.resize(p.size());
  // A ghost's shift is read by no one (ProcessShare): left as it was.
  const uint8_t* ghost = state.share.ghost.empty() ? nullptr : state.share.ghost.data();
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    if (ghost && ghost[i]) continue;
    const Eigen::Vector3i cell = state.grid.SortedCell(uint32_t(i));
    const Vec3& x = p.position[i];
    Vec3 concentration = Vec3::Zero();  // grad C_i
    Real divergence = 0;                // div r_i
    ForEachWithin(state.grid, cell, x, support, [&](uint32_t j, const Vec3& xij, Real r) {
      const Vec3 grad = GradW(xij, r, kernel);
      const Real v = mass / p.density[j];
      concentration += v * grad;
      divergence -= v * xij.dot(grad);
    });
    ForEachWithin(boundary.grid(), cell, x, support, [&](uint32_t b, const Vec3& xib, Real r) {
      const Vec3 grad = GradW(xib, r, kernel);
      concentration += volume[b] * grad;
      divergence -= volume[b] * xib.dot(grad);
    });
    const Real scale = -(coefficient * p.velocity[i].norm());
    data.shift[i] = divergence < free_surface ? Vec3::Zero() : Vec3(scale * concentration);
  }
}

}  // namespace dysa::physical
