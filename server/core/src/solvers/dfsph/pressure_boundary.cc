#include "solvers/dfsph/pressure_boundary.h"

#include <algorithm>
#include <cstdint>

#include "dysa/core/kernels.h"
#include "solvers/physical/physical_passes.h"
#include "sph_loops.h"

namespace dysa::dfsph {

void ListBoundaryNeighbors(const Model& model, BenderKoschierData& data, State& state) {
  const BoundaryParticles& boundary = *data.boundary;
  const ParticleArrays& p = state.particles;
  const NeighborPairs& pairs = data.boundary_pairs;
  BoundaryNeighbors& bn = data.boundary_neighbors;
  const int64_t n = int64_t(p.size());
  const int64_t nb = int64_t(boundary.size());
  // The transpose, by counting: b's neighbours in fluid order, whatever the thread count.
  bn.begin.assign(size_t(nb) + 1, 0);
  for (uint32_t b : pairs.other) ++bn.begin[b + 1];
  for (int64_t b = 0; b < nb; ++b) bn.begin[b + 1] += bn.begin[b];
  bn.fluid.resize(pairs.other.size());
  bn.weight.resize(pairs.other.size());
  bn.hydrostatic.resize(size_t(nb));
  bn.kappa.assign(size_t(nb), Real(0));
  {
    std::vector<size_t>& next = bn.fill;
    next.assign(bn.begin.begin(), bn.begin.end() - 1);
    for (int64_t i = 0; i < n; ++i) {
      for (size_t k = pairs.begin[i]; k < pairs.begin[i + 1]; ++k) {
        bn.fluid[next[pairs.other[k]]++] = uint32_t(i);
      }
    }
  }
  const PhysicalKernel<Real> kernel = model.Kernel();
  const Real gy = Real(physical::GravityAt(model.params, state.time));
  const Real* bx = boundary.grid().xs().data();
  const Real* by = boundary.grid().ys().data();
  const Real* bz = boundary.grid().zs().data();
#pragma omp parallel for schedule(static)
  for (int64_t b = 0; b < nb; ++b) {
    const Vec3 xb(bx[b], by[b], bz[b]);
    Real sum = 0, head = 0;
    for (size_t k = bn.begin[b]; k < bn.begin[b + 1]; ++k) {
      // Across a periodic axis the fluid neighbour is the nearest image of x_i.
      const Vec3 xbi = model.MinimumImage(Vec3(xb - p.position[bn.fluid[k]]));
      const Real w = kernel.W(xbi.norm());
      bn.weight[k] = w;
      sum += w;
      head += w * p.density[bn.fluid[k]] * xbi.y();
    }
    const Real inv = sum > 0 ? 1 / sum : Real(0);
    for (size_t k = bn.begin[b]; k < bn.begin[b + 1]; ++k) bn.weight[k] *= inv;
    bn.hydrostatic[b] = std::max(gy * head * inv, Real(0));
  }
  const Real rho0 = Real(model.params.rest_density);
  const Real mu = Real(model.gradient_moment);
  const Real* volume = boundary.padded_volume();
  data.acceleration.resize(size_t(n));
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    Vec3 sum = Vec3::Zero();
    for (size_t k = pairs.begin[i]; k < pairs.begin[i + 1]; ++k) {
      const uint32_t b = pairs.other[k];
      sum += (volume[b] * bn.hydrostatic[b]) * pairs.grad_w[k];
    }
    const Real rho = p.density[i];
    data.acceleration[i] = (-rho0 / (rho * rho * mu)) * sum;
  }
}

void ExtrapolateKappa(const Real* kappa_over_rho, BoundaryNeighbors& bn) {
  const int64_t nb = int64_t(bn.kappa.size());
#pragma omp parallel for schedule(static)
  for (int64_t b = 0; b < nb; ++b) {
    Real kappa = 0;
    for (size_t k = bn.begin[b]; k < bn.begin[b + 1]; ++k) {
      kappa += bn.weight[k] * kappa_over_rho[bn.fluid[k]];
    }
    bn.kappa[b] = kappa;
  }
}

}  // namespace dysa::dfsph
