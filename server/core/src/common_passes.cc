#include "common_passes.h"

#include <cmath>

namespace dysa {

void SortParticlesIntoGrid(const Model& model, State& state) {
  ParticleArrays& p = state.particles;
  state.grid.Configure(model.domain, Real(model.params.smoothing_radius), model.periodic);
  state.grid.Sort(p.predicted);
  const auto order = state.grid.order();
  PermuteInPlace(order, p.position, state.vec3_scratch);
  PermuteInPlace(order, p.velocity, state.vec3_scratch);
  PermuteInPlace(order, p.predicted, state.vec3_scratch);
  PermuteInPlace(order, p.id, state.index_scratch);
}

namespace {

void CollideWithSphere(const SphereObstacle& s, Real damping, Vec3& x, Vec3& v) {
  const Vec3 c = s.center.cast<Real>();
  const Real r = Real(s.radius);
  const Vec3 d = x - c;
  const Real dist2 = d.squaredNorm();
  if (dist2 >= r * r) return;
  const Real dist = std::sqrt(dist2);
  const Vec3 n = dist > 0 ? Vec3(d / dist) : Vec3::UnitY();
  x = c + n * r;
  const Real vn = v.dot(n);
  if (vn < 0) v -= (1 + damping) * vn * n;
}

void CollideWithBox(const BoxObstacle& b, Real damping, Vec3& x, Vec3& v) {
  const Vec3 lo = b.box.min.cast<Real>();
  const Vec3 hi = b.box.max.cast<Real>();
  if (!((x.array() > lo.array()).all() && (x.array() < hi.array()).all())) return;
  // Leave through the nearest face.
  int axis = 0;
  Real best = x[0] - lo[0];
  Real face = lo[0];
  Real outward = -1;
  for (int a = 0; a < 3; ++a) {
    if (x[a] - lo[a] < best) best = x[a] - lo[a], axis = a, face = lo[a], outward = -1;
    if (hi[a] - x[a] < best) best = hi[a] - x[a], axis = a, face = hi[a], outward = 1;
  }
  x[axis] = face;
  if (v[axis] * outward < 0) v[axis] = -v[axis] * damping;
}

}  // namespace

void CollideWithObstacles(const Model& model, State& state) {
  ParticleArrays& p = state.particles;
  const Real damping = Real(model.params.collision_damping);
  const int64_t n = static_cast<int64_t>(p.size());
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    for (const SphereObstacle& s : model.spheres)
      CollideWithSphere(s, damping, p.position[i], p.velocity[i]);
    for (const BoxObstacle& b : model.boxes)
      CollideWithBox(b, damping, p.position[i], p.velocity[i]);
  }
}

}  // namespace dysa
