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
  state.grid.Configure(model.domain, Real(model.kernel_support), model.periodic,
                       model.grid_cells_per_support);
  state.grid.Sort(p.position);
  const auto order = state.grid.order();
  PermuteInPlace(order, p.position, state.vec3_scratch);
  PermuteInPlace(order, p.velocity, state.vec3_scratch);
  PermuteInPlace(order, p.id, state.index_scratch);
}

void AddViscosity(const Model& model, PhysicalData& data, State& state) {
  ParticleArrays& p = state.particles;
  const PhysicalKernel<Real> kernel = model.Kernel();
  const Real support = kernel.support;
  const Real h = Real(model.SmoothingLength());
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
      sum += (vx / (p.density[j] * (r * r + eps))) * GradW(xij, r, kernel);
    });
    data.acceleration[i] += scale * sum;
  }
}

void ExtrapolateWallVelocity(const Model& model, PhysicalData& data, State& state) {
  const BoundaryParticles& boundary = *data.boundary;
  const ParticleArrays& p = state.particles;
  const PhysicalKernel<Real> kernel = model.Kernel();
  const Real support = kernel.support;
  const NeighborGrid& bgrid = boundary.grid();
  const Real* bx = bgrid.xs().data();
  const Real* by = bgrid.ys().data();
  const Real* bz = bgrid.zs().data();
  const std::span<const uint8_t> no_slip = boundary.no_slip();
  const int64_t nb = int64_t(boundary.size());
  data.boundary_velocity.resize(size_t(nb));
  // v_b = -(Shepard mean of the fluid's velocity around b): the wall's velocity (0) at the
  // surface halfway between b and its fluid neighbours.
  const ProcessShare& share = state.share;
#pragma omp parallel for schedule(static)
  for (int64_t b = 0; b < nb; ++b) {
    Vec3 weighted = Vec3::Zero();
    Real weights = 0;
    if (no_slip[b] && share.NeedsBoundaryCell(bgrid.SortedCell(uint32_t(b)))) {
      const Vec3 x(bx[b], by[b], bz[b]);
      ForEachWithin(state.grid, bgrid.SortedCell(uint32_t(b)), x, support,
                    [&](uint32_t f, const Vec3&, Real r) {
                      const Real w = kernel.W(r);
                      weighted += w * p.velocity[f];
                      weights += w;
                    });
    }
    data.boundary_velocity[b] = weights > 0 ? Vec3(-weighted / weights) : Vec3::Zero();
  }
}

void AddWallViscosity(const Model& model, PhysicalData& data, State& state) {
  ExtrapolateWallVelocity(model, data, state);
  const BoundaryParticles& boundary = *data.boundary;
  ParticleArrays& p = state.particles;
  const PhysicalKernel<Real> kernel = model.Kernel();
  const Real support = kernel.support;
  const Real h = Real(model.SmoothingLength());
  const Real eps = Real(0.01) * h * h;
  // 2 (dim + 2) nu / lambda, as AddViscosity
  const Real scale = Real(10 * model.params.kinematic_viscosity / model.viscosity_moment);
  const std::span<const uint8_t> no_slip = boundary.no_slip();
  const Real* volume = boundary.padded_volume();
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
                    sum += (volume[b] * vx / (r * r + eps)) * GradW(xib, r, kernel);
                  });
    data.acceleration[i] += scale * sum;
  }
}

std::vector<ObstacleFrame> ObstacleFramesOverStep(const Model& model, double t, double dt) {
  if (!model.HasMovingObstacles()) return {};
  std::vector<ObstacleFrame> frames;
  auto add = [&](const ObstacleMotion& m) {
    const Vec3d start = m.DisplacementAt(t);
    const Vec3d velocity =
        dt > 0 ? Vec3d((m.DisplacementAt(t + dt) - start) / dt) : m.VelocityAt(t);
    frames.push_back({start, velocity.cast<Real>()});
  };
  for (const BoxObstacle& b : model.boxes) add(b.motion);
  for (const SphereObstacle& s : model.spheres) add(s.motion);
  return frames;
}

void MoveBoundary(const Model& model, PhysicalData& data, State& state) {
  std::vector<Vec3d> displacement;
  std::vector<Vec3> velocity;
  double fastest = 0;
  auto add = [&](const ObstacleMotion& m) {
    displacement.push_back(m.DisplacementAt(state.time));
    const Vec3d u = m.VelocityAt(state.time);
    velocity.push_back(u.cast<Real>());
    fastest = std::max(fastest, u.norm());
  };
  for (const BoxObstacle& b : model.boxes) add(b.motion);
  for (const SphereObstacle& s : model.spheres) add(s.motion);
  data.boundary->MoveObstacles(displacement, velocity);
  data.max_obstacle_speed = fastest;
}

namespace {

// Calls visit(dist, n, u) for every surface (a wall across a non-periodic axis, a sphere, a box)
// within `range` of x, with dist the distance to it, n the unit normal from it to x and u its
// velocity (frames: the obstacles' displacements and velocities; empty: all at rest). A point
// inside an obstacle gets distance 0 and the way out: the sphere's radial direction, the box's
// nearest face.
template <class Visit>
void ForEachSurfaceWithin(const Model& model, std::span<const ObstacleFrame> frames, const Vec3& x,
                          Real range, Visit&& visit) {
  const Vec3 at_rest = Vec3::Zero();
  for (int k = 0; k < 3; ++k) {
    if (model.periodic[k]) continue;  // no wall across a periodic axis
    const Real below = x[k] - Real(model.domain.min[k]);
    const Real above = Real(model.domain.max[k]) - x[k];
    if (below < range) visit(below, Vec3(Vec3::Unit(k)), at_rest);
    if (above < range) visit(above, Vec3(-Vec3::Unit(k)), at_rest);
  }
  const size_t boxes = model.boxes.size();
  for (size_t o = 0; o < model.spheres.size(); ++o) {
    const SphereObstacle& s = model.spheres[o];
    const ObstacleFrame* f = frames.empty() ? nullptr : &frames[boxes + o];
    const Vec3 d =
        x - (f ? Vec3((s.center + f->displacement).cast<Real>()) : Vec3(s.center.cast<Real>()));
    const Real norm = d.norm();
    const Real dist = norm - Real(s.radius);
    if (norm > 0 && dist < range)
      visit(std::max(dist, Real(0)), Vec3(d / norm), f ? f->velocity : at_rest);
  }
  for (size_t o = 0; o < boxes; ++o) {
    const BoxObstacle& b = model.boxes[o];
    const ObstacleFrame* f = frames.empty() ? nullptr : &frames[o];
    const Vec3 u = f ? f->velocity : at_rest;
    const Vec3 bl =
        f ? Vec3((b.box.min + f->displacement).cast<Real>()) : Vec3(b.box.min.cast<Real>());
    const Vec3 bh =
        f ? Vec3((b.box.max + f->displacement).cast<Real>()) : Vec3(b.box.max.cast<Real>());
    const Vec3 nearest = x.cwiseMax(bl).cwiseMin(bh);
    const Vec3 d = x - nearest;
    const Real dist = d.norm();
    if (dist > 0) {
      if (dist < range) visit(dist, Vec3(d / dist), u);
      continue;
    }
    int axis = 0;
    Real depth = x[0] - bl[0], sign = -1;
    for (int k = 0; k < 3; ++k) {
      if (x[k] - bl[k] < depth) depth = x[k] - bl[k], axis = k, sign = -1;
      if (bh[k] - x[k] < depth) depth = bh[k] - x[k], axis = k, sign = 1;
    }
    visit(Real(0), Vec3(sign * Vec3::Unit(axis)), u);
  }
}

}  // namespace

void LimitApproachToSurfaces(const Model& model, std::span<const ObstacleFrame> frames, Real dt,
                             const Vec3& x, Vec3& v) {
  const Real r0 = Real(model.params.wall_contact_range * model.params.particle_spacing);
  // The surfaces this step could bring it to: a moving one closes in at up to its own speed.
  Real approach = v.norm();
  for (const ObstacleFrame& f : frames) approach = std::max(approach, v.norm() + f.velocity.norm());
  const Real reach = Real(0.5) * r0 + approach * dt;
  // Each surface allows the velocities with (v - u) . n >= allowed (<= 0), u its velocity:
  // half-spaces that all hold v = u for a single surface. Cutting v onto one can break another
  // (a sphere's normal tilted towards a wall), so the cuts are repeated, a few sweeps of
  // alternating projections onto their intersection (which a surface closing in on another
  // can leave empty: then the last sweep's cut stands and the pressure does the rest).
  for (int sweep = 0; sweep < 4; ++sweep) {
    bool cut = false;
    ForEachSurfaceWithin(model, frames, x, reach,
                         [&](Real dist, const Vec3& normal, const Vec3& u) {
                           // The approach the step may take: down to r0 / 2 from the surface (exact
                           // for a wall; a curve within r0 bends away from the tangent plane, so it
                           // is kept at least as far).
                           const Real allowed = -std::max(dist - Real(0.5) * r0, Real(0)) / dt;
                           const Real vn = (v - u).dot(normal);
                           if (vn < allowed) v += (allowed - vn) * normal, cut = true;
                         });
    if (!cut) break;
  }
}

}  // namespace dysa::physical
