// Passes shared by every solver.
#pragma once

#include "dysa/core/model.h"
#include "dysa/core/state.h"

namespace dysa {

// Sorts particles by grid cell (cell edge = smoothing radius) using the predicted positions and
// reorders every per-particle array that carries over between steps into that order.
void SortParticlesIntoGrid(const Model& model, State& state);

// Pushes particles out of static spheres and boxes to the nearest surface point and reflects the
// normal velocity scaled by the collision damping.
void CollideWithObstacles(const Model& model, State& state);

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
