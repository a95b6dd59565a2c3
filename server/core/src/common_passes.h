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
// velocity is reflected and scaled by `damping`.
inline void CollideWithDomainWalls(const Aabb& domain, Real damping, Vec3& x, Vec3& v) {
  for (int a = 0; a < 3; ++a) {
    const Real lo = Real(domain.min[a]);
    const Real hi = Real(domain.max[a]);
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
