// The domain box's walls, shared by every solver: the seed's collision, and the physical solvers'
// last-resort clamp after the wall contact (the CPU passes and the GPU kernels alike).
#pragma once

#include "dysa/core/types.h"

namespace dysa {

// Clamps a particle into the domain box; where it crossed a wall moving outwards, the normal
// velocity is reflected and scaled by `damping`. Across a periodic axis it re-enters through the
// opposite face instead (x - L or x + L; a step never crosses more than a cell).
inline void CollideWithDomainWalls(const Aabb& domain, const Periodicity& periodic, Real damping,
                                   Vec3& x, Vec3& v) {
  for (int a = 0; a < 3; ++a) {
    const Real lo = Real(domain.min[a]);
    const Real hi = Real(domain.max[a]);
    if (periodic[a]) {
      const Real length = hi - lo;
      if (x[a] >= hi) x[a] -= length;
      if (x[a] < lo) x[a] += length;
      // Rounding of x + L can land on hi itself; hi is lo's image.
      if (!(x[a] < hi)) x[a] = lo;
      continue;
    }
    if (x[a] <= lo) {
      x[a] = lo;
      if (v[a] < 0) v[a] = -v[a] * damping;
    } else if (x[a] >= hi) {
      x[a] = hi;
      if (v[a] > 0) v[a] = -v[a] * damping;
    }
  }
}

}  // namespace dysa
