#include "solvers/physical/physical_passes.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <span>

#include "dysa/core/kernels.h"
#include "sph_loops.h"

namespace dysa::physical {

double GravityAt(const Params& params, double time) {
  const double ramp = params.gravity_ramp_time;
  if (ramp <= 0 || time >= ramp) return params.gravity;
  return params.gravity * 0.5 * (1 - std::cos(std::numbers::pi * time / ramp));
}

void SortIntoGrid(const Model& model, State& state) {
  ParticleArrays& p = state.particles;
  state.grid.Configure(model.domain, Real(model.kernel_support), model.periodic);
  state.grid.Sort(p.position);
  const auto order = state.grid.order();
  PermuteInPlace(order, p.position, state.vec3_scratch);
  PermuteInPlace(order, p.velocity, state.vec3_scratch);
  PermuteInPlace(order, p.id, state.index_scratch);
}

void AddViscosity(const Model& model, PhysicalData& data, State& state) {
  ParticleArrays& p = state.particles;
  const Real support = Real(model.kernel_support);
  const Real h = Real(model.params.particle_spacing);  // smoothing length, support / 2
  const Real eps = Real(0.01) * h * h;
  // 2 (dim + 2) nu m / lambda, lambda the lattice's viscosity moment (kernels.h)
  const Real scale =
      Real(10 * model.params.kinematic_viscosity * model.particle_mass / model.viscosity_moment);
  const int64_t n = int64_t(p.size());
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    const Eigen::Vector3i cell = state.grid.SortedCell(uint32_t(i));
    const Vec3& x = p.position[i];
    const Vec3& v = p.velocity[i];
    Vec3 sum = Vec3::Zero();
    ForEachWithin(state.grid, cell, x, support, [&](uint32_t j, const Vec3& xij, Real r) {
      if (r <= 0) return;
      const Real vx = (v - p.velocity[j]).dot(xij);
      sum += (vx / (p.density[j] * (r * r + eps))) * GradW(xij, r, support);
    });
    data.acceleration[i] += scale * sum;
  }
}

void AddWallViscosity(const Model& model, PhysicalData& data, State& state) {
  const BoundaryParticles& boundary = *data.boundary;
  ParticleArrays& p = state.particles;
  const Real support = Real(model.kernel_support);
  const Real h = Real(model.params.particle_spacing);
  const Real eps = Real(0.01) * h * h;
  // 2 (dim + 2) nu / lambda, as AddViscosity
  const Real scale = Real(10 * model.params.kinematic_viscosity / model.viscosity_moment);
  const NeighborGrid& bgrid = boundary.grid();
  const Real* bx = bgrid.xs().data();
  const Real* by = bgrid.ys().data();
  const Real* bz = bgrid.zs().data();
  const std::span<const uint8_t> no_slip = boundary.no_slip();
  const Real* volume = boundary.padded_volume();
  const int64_t nb = int64_t(boundary.size());
  data.boundary_velocity.resize(size_t(nb));
  // v_b = -(Shepard mean of the fluid's velocity around b): the wall's velocity (0) at the
  // surface halfway between b and its fluid neighbours.
#pragma omp parallel for schedule(static)
  for (int64_t b = 0; b < nb; ++b) {
    Vec3 weighted = Vec3::Zero();
    Real weights = 0;
    if (no_slip[b]) {
      const Vec3 x(bx[b], by[b], bz[b]);
      ForEachWithin(state.grid, bgrid.SortedCell(uint32_t(b)), x, support,
                    [&](uint32_t f, const Vec3&, Real r) {
                      const Real w = CubicSpline<Real>::W(r, support);
                      weighted += w * p.velocity[f];
                      weights += w;
                    });
    }
    data.boundary_velocity[b] = weights > 0 ? Vec3(-weighted / weights) : Vec3::Zero();
  }
  const int64_t n = int64_t(p.size());
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    const Eigen::Vector3i cell = state.grid.SortedCell(uint32_t(i));
    const Vec3& v = p.velocity[i];
    Vec3 sum = Vec3::Zero();
    ForEachWithin(boundary.grid(), cell, p.position[i], support,
                  [&](uint32_t b, const Vec3& xib, Real r) {
                    if (!no_slip[b] || r <= 0) return;
                    const Real vx = (v - data.boundary_velocity[b]).dot(xib);
                    sum += (volume[b] * vx / (r * r + eps)) * GradW(xib, r, support);
                  });
    data.acceleration[i] += scale * sum;
  }
}

namespace {

// Calls visit(dist, n) for every surface (a wall across a non-periodic axis, a sphere, a box)
// within `range` of x, with dist the distance to it and n the unit normal from it to x. A
// point inside an obstacle gets distance 0 and the way out: the sphere's radial direction, the
// box's nearest face.
template <class Visit>
void ForEachSurfaceWithin(const Model& model, const Vec3& x, Real range, Visit&& visit) {
  for (int k = 0; k < 3; ++k) {
    if (model.periodic[k]) continue;  // no wall across a periodic axis
    const Real below = x[k] - Real(model.domain.min[k]);
    const Real above = Real(model.domain.max[k]) - x[k];
    if (below < range) visit(below, Vec3(Vec3::Unit(k)));
    if (above < range) visit(above, Vec3(-Vec3::Unit(k)));
  }
  for (const SphereObstacle& s : model.spheres) {
    const Vec3 d = x - s.center.cast<Real>();
    const Real norm = d.norm();
    const Real dist = norm - Real(s.radius);
    if (norm > 0 && dist < range) visit(std::max(dist, Real(0)), Vec3(d / norm));
  }
  for (const BoxObstacle& b : model.boxes) {
    const Vec3 bl = b.box.min.cast<Real>(), bh = b.box.max.cast<Real>();
    const Vec3 nearest = x.cwiseMax(bl).cwiseMin(bh);
    const Vec3 d = x - nearest;
    const Real dist = d.norm();
    if (dist > 0) {
      if (dist < range) visit(dist, Vec3(d / dist));
      continue;
    }
    int axis = 0;
    Real depth = x[0] - bl[0], sign = -1;
    for (int k = 0; k < 3; ++k) {
      if (x[k] - bl[k] < depth) depth = x[k] - bl[k], axis = k, sign = -1;
      if (bh[k] - x[k] < depth) depth = bh[k] - x[k], axis = k, sign = 1;
    }
    visit(Real(0), Vec3(sign * Vec3::Unit(axis)));
  }
}

}  // namespace

void LimitApproachToSurfaces(const Model& model, Real dt, const Vec3& x, Vec3& v) {
  const Real r0 = Real(kContactRange * model.params.particle_spacing);
  const Real reach = Real(0.5) * r0 + v.norm() * dt;  // the surfaces this step could bring it to
  // Each surface allows the velocities with v . n >= allowed (<= 0): half-spaces that all hold
  // v = 0. Cutting v onto one can break another (a sphere's normal tilted towards a wall), so
  // the cuts are repeated, a few sweeps of alternating projections onto their intersection.
  for (int sweep = 0; sweep < 4; ++sweep) {
    bool cut = false;
    ForEachSurfaceWithin(model, x, reach, [&](Real dist, const Vec3& normal) {
      // The approach the step may take: down to r0 / 2 from the surface (exact for a wall; a
      // curve within r0 bends away from the tangent plane, so it is kept at least as far).
      const Real allowed = -std::max(dist - Real(0.5) * r0, Real(0)) / dt;
      const Real vn = v.dot(normal);
      if (vn < allowed) v += (allowed - vn) * normal, cut = true;
    });
    if (!cut) break;
  }
}

}  // namespace dysa::physical
