// Neighbour loops shared by the physical solvers (scalar, gather-only).
#pragma once

#include <cmath>
#include <cstdint>

#include "dysa/core/kernels.h"
#include "dysa/core/neighbor_grid.h"

namespace dysa {

// Calls visit(j, x_ij, r) for every point j of `grid` within `support` of `x` (cell `cell` of
// the grid's layout), in the grid's fixed order; x_ij = x - x_j, r = |x_ij|, to the image of j
// nearest to x across a periodic axis.
template <class Visit>
inline void ForEachWithin(const NeighborGrid& grid, const Eigen::Vector3i& cell, const Vec3& x,
                          Real support, Visit&& visit) {
  const Real* xs = grid.xs().data();
  const Real* ys = grid.ys().data();
  const Real* zs = grid.zs().data();
  const Real support2 = support * support;
  grid.ForEachNeighborRun(cell, [&](uint32_t begin, uint32_t end, const Vec3& shift) {
    const Vec3 q = x + shift;
    for (uint32_t j = begin; j < end; ++j) {
      const Vec3 xij(q.x() - xs[j], q.y() - ys[j], q.z() - zs[j]);
      const Real r2 = xij.squaredNorm();
      if (r2 < support2) visit(j, xij, std::sqrt(r2));
    }
  });
}

// grad W(x_ij) = dW/dr x_ij / r (zero at r = 0).
inline Vec3 GradW(const Vec3& xij, Real r, const PhysicalKernel<Real>& kernel) {
  return r > 0 ? Vec3(xij * (kernel.dW(r) / r)) : Vec3::Zero();
}

}  // namespace dysa
