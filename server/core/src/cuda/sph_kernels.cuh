// Device code shared by the physical solvers' pipelines (wcsph_pipeline.cu,
// dfsph_pipeline.cu): the cubic spline, the neighbour loop, the viscosity passes, the wall
// contact and the integration, each the CPU's code (kernels.h, sph_loops.h,
// physical_passes.cc) with the same operations in the same order.
#pragma once

#include <cuda_runtime.h>

#include <cstdint>

#include "cuda/device_grid.cuh"
#include "cuda/gpu_types.h"

namespace dysa::cuda::sph {
// Each file that includes this gets its own copy of these kernels.
namespace {

constexpr float kPi = 3.14159265358979323846f;  // std::numbers::pi_v<float>

// CubicSpline<float> and WendlandC2<float> (kernels.h), chosen by SphConstants::kernel as
// PhysicalKernel chooses on the CPU.
__device__ float CubicSigma(float support) { return 8.0f / (kPi * support * support * support); }
__device__ float WendlandSigma(float support) {
  return 21.0f / (2.0f * kPi * support * support * support);
}
__device__ float KernelW(float r, const SphConstants& c) {
  const float support = c.support;
  const float q = r / support;
  if (c.kernel == kWendlandC2) {
    if (q > 1) return 0;
    const float v = 1 - q;
    const float v2 = v * v;
    return WendlandSigma(support) * (v2 * v2) * (4.0f * q + 1);
  }
  if (q > 1) return 0;
  if (q <= 0.5f) return CubicSigma(support) * (6.0f * (q * q * q - q * q) + 1);
  const float v = 1 - q;
  return CubicSigma(support) * 2.0f * v * v * v;
}
__device__ float KernelDW(float r, const SphConstants& c) {
  const float support = c.support;
  const float q = r / support;
  if (c.kernel == kWendlandC2) {
    if (q > 1) return 0;
    const float v = 1 - q;
    return -(20.0f * WendlandSigma(support) / support) * q * (v * v * v);
  }
  if (q > 1) return 0;
  const float scale = 6.0f * CubicSigma(support) / support;
  if (q <= 0.5f) return scale * q * (3.0f * q - 2.0f);
  const float v = 1 - q;
  return -scale * v * v;
}

struct F3 {
  float x, y, z;
};
// Eigen's squaredNorm() and dot() of 3-vectors: x + (y + z).
__device__ float Dot(F3 a, F3 b) { return a.x * b.x + (a.y * b.y + a.z * b.z); }
__device__ float Norm2(F3 a) { return Dot(a, a); }
// a += s v, component by component (no fused multiply-add: the kernels build with --fmad=false).
__device__ void AddScaled(F3& a, float s, F3 v) { a.x += s * v.x, a.y += s * v.y, a.z += s * v.z; }
// GradW (sph_loops.h): x_ij dW/dr / r, zero at r = 0; its factor dW/dr / r.
// wcsph's carried density held within its range (BoundCarriedDensity, becker_teschner_solver.h).
__device__ float BoundCarriedDensity(const SphConstants& c, float rho) {
  return rho < c.density_min ? c.density_min : (rho > c.density_max ? c.density_max : rho);
}

__device__ float GradFactor(float r, const SphConstants& c) {
  return r > 0 ? KernelDW(r, c) / r : 0.0f;
}

struct Points {
  const float *x, *y, *z;
};

// ForEachWithin (sph_loops.h): visit(j, x_ij, r) for every point j of `grid` within `support` of
// `p` (in cell `cell`), in the grid's order.
template <class Visit>
__device__ void ForEachWithin(const DeviceGrid& grid, Points pts, int3 cell, F3 p, float support,
                              Visit&& visit) {
  const float support2 = support * support;
  grid.ForEachNeighborRun(cell, [&](uint32_t begin, uint32_t end, float sx, float sy, float sz) {
    const F3 q{p.x + sx, p.y + sy, p.z + sz};
    for (uint32_t j = begin; j < end; ++j) {
      const F3 xij{q.x - pts.x[j], q.y - pts.y[j], q.z - pts.z[j]};
      const float r2 = Norm2(xij);
      if (r2 < support2) visit(j, xij, sqrtf(r2));
    }
  });
}

struct Fluid {
  float *x, *y, *z, *vx, *vy, *vz;
  uint32_t* id;
  float *density, *pressure;
  float *ax, *ay, *az;
  float* p_over_rho2;
};

struct Boundary {
  const float *x, *y, *z, *volume;
  const uint8_t* no_slip;
  float* pressure;      // Pa
  float* p_over_rho2;   // Pa m^6/kg^2
  float *vx, *vy, *vz;  // m/s, the mirrored fluid velocity at no-slip samples
  uint32_t n;
  // m/s, each sample's obstacle velocity (MovingBoundary); null when no obstacle moves.
  const float *ux, *uy, *uz;
};

// v_i - v_b of the continuity equation's wall term: v_i itself unless the samples move.
__device__ F3 RelativeToSample(const Boundary& b, F3 v, uint32_t k) {
  return b.ux ? F3{v.x - b.ux[k], v.y - b.uy[k], v.z - b.uz[k]} : v;
}

__global__ void ViscosityKernel(DeviceGrid fluid_grid, Fluid f, SphConstants c, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const F3 x{f.x[i], f.y[i], f.z[i]};
  const F3 v{f.vx[i], f.vy[i], f.vz[i]};
  F3 sum{0, 0, 0};
  ForEachWithin(fluid_grid, {f.x, f.y, f.z}, fluid_grid.SortedCell(i), x, c.support,
                [&](uint32_t j, F3 xij, float r) {
                  if (r <= 0) return;
                  const float vx = Dot({v.x - f.vx[j], v.y - f.vy[j], v.z - f.vz[j]}, xij);
                  const float s = vx / (f.density[j] * (r * r + c.eps));
                  const float g = GradFactor(r, c);
                  sum.x += s * (xij.x * g), sum.y += s * (xij.y * g), sum.z += s * (xij.z * g);
                });
  f.ax[i] += c.viscosity_scale * sum.x;
  f.ay[i] += c.viscosity_scale * sum.y;
  f.az[i] += c.viscosity_scale * sum.z;
}

// v_b = -(the Shepard mean of the fluid's velocity around b), at no-slip samples.
__global__ void BoundaryVelocityKernel(DeviceGrid fluid_grid, DeviceGrid boundary_grid, Fluid f,
                                       Boundary b, SphConstants c) {
  const uint32_t k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k >= b.n) return;
  F3 weighted{0, 0, 0};
  float weights = 0;
  if (b.no_slip[k]) {
    const F3 x{b.x[k], b.y[k], b.z[k]};
    ForEachWithin(fluid_grid, {f.x, f.y, f.z}, boundary_grid.SortedCell(k), x, c.support,
                  [&](uint32_t j, F3, float r) {
                    const float w = KernelW(r, c);
                    weighted.x += w * f.vx[j], weighted.y += w * f.vy[j];
                    weighted.z += w * f.vz[j];
                    weights += w;
                  });
  }
  b.vx[k] = weights > 0 ? -weighted.x / weights : 0.0f;
  b.vy[k] = weights > 0 ? -weighted.y / weights : 0.0f;
  b.vz[k] = weights > 0 ? -weighted.z / weights : 0.0f;
}

__global__ void WallViscosityKernel(DeviceGrid fluid_grid, DeviceGrid boundary_grid, Fluid f,
                                    Boundary b, SphConstants c, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const F3 x{f.x[i], f.y[i], f.z[i]};
  const F3 v{f.vx[i], f.vy[i], f.vz[i]};
  F3 sum{0, 0, 0};
  ForEachWithin(boundary_grid, {b.x, b.y, b.z}, fluid_grid.SortedCell(i), x, c.support,
                [&](uint32_t k, F3 xib, float r) {
                  if (!b.no_slip[k] || r <= 0) return;
                  const float vx = Dot({v.x - b.vx[k], v.y - b.vy[k], v.z - b.vz[k]}, xib);
                  const float s = b.volume[k] * vx / (r * r + c.eps);
                  const float g = GradFactor(r, c);
                  sum.x += s * (xib.x * g), sum.y += s * (xib.y * g), sum.z += s * (xib.z * g);
                });
  f.ax[i] += c.wall_viscosity_scale * sum.x;
  f.ay[i] += c.wall_viscosity_scale * sum.y;
  f.az[i] += c.wall_viscosity_scale * sum.z;
}

__global__ void MaximaInputsKernel(Fluid f, float* speed2, float* acceleration2, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  speed2[i] = Norm2({f.vx[i], f.vy[i], f.vz[i]});
  acceleration2[i] = Norm2({f.ax[i], f.ay[i], f.az[i]});
}

struct Surfaces {
  const SphereObstacle* spheres;
  int sphere_count;
  const BoxObstacle* boxes;
  int box_count;
  bool periodic[3];
  float obstacle_speed;  // m/s, the fastest obstacle's |u| over the step (0: all static)
};

// ForEachSurfaceWithin (solvers/physical/physical_passes.cc), with the same unit vectors (-0
// components included) and the same order: walls, spheres, boxes; visit(dist, n, u), u the
// surface's velocity (the obstacles are where the host placed them for the step).
template <class Visit>
__device__ void ForEachSurfaceWithin(const SphConstants& c, const Surfaces& s, F3 x, float range,
                                     Visit&& visit) {
  const float xa[3] = {x.x, x.y, x.z};
  for (int k = 0; k < 3; ++k) {
    if (s.periodic[k]) continue;
    const float below = xa[k] - c.domain_lo[k];
    const float above = c.domain_hi[k] - xa[k];
    const F3 unit{k == 0 ? 1.0f : 0.0f, k == 1 ? 1.0f : 0.0f, k == 2 ? 1.0f : 0.0f};
    const F3 at_rest{0, 0, 0};
    if (below < range) visit(below, unit, at_rest);
    if (above < range) visit(above, F3{-unit.x, -unit.y, -unit.z}, at_rest);
  }
  for (int o = 0; o < s.sphere_count; ++o) {
    const SphereObstacle& sphere = s.spheres[o];
    const F3 d{x.x - sphere.center[0], x.y - sphere.center[1], x.z - sphere.center[2]};
    const float norm = sqrtf(Norm2(d));
    const float dist = norm - sphere.radius;
    if (norm > 0 && dist < range) {
      const F3 u{sphere.velocity[0], sphere.velocity[1], sphere.velocity[2]};
      visit(dist < 0.0f ? 0.0f : dist, F3{d.x / norm, d.y / norm, d.z / norm}, u);  // std::max
    }
  }
  for (int o = 0; o < s.box_count; ++o) {
    const BoxObstacle& box = s.boxes[o];
    const F3 u{box.velocity[0], box.velocity[1], box.velocity[2]};
    float nearest[3];
    for (int k = 0; k < 3; ++k) {
      const float hi_side = xa[k] < box.lo[k] ? box.lo[k] : xa[k];  // std::max(x, lo)
      nearest[k] = box.hi[k] < hi_side ? box.hi[k] : hi_side;       // std::min(., hi)
    }
    const F3 d{x.x - nearest[0], x.y - nearest[1], x.z - nearest[2]};
    const float dist = sqrtf(Norm2(d));
    if (dist > 0) {
      if (dist < range) visit(dist, F3{d.x / dist, d.y / dist, d.z / dist}, u);
      continue;
    }
    int axis = 0;
    float depth = xa[0] - box.lo[0], sign = -1;
    for (int k = 0; k < 3; ++k) {
      if (xa[k] - box.lo[k] < depth) depth = xa[k] - box.lo[k], axis = k, sign = -1;
      if (box.hi[k] - xa[k] < depth) depth = box.hi[k] - xa[k], axis = k, sign = 1;
    }
    visit(0.0f,
          F3{sign * (axis == 0 ? 1.0f : 0.0f), sign * (axis == 1 ? 1.0f : 0.0f),
             sign * (axis == 2 ? 1.0f : 0.0f)},
          u);
  }
}

__device__ void CollideWithWall(float lo, float hi, bool periodic, float& x, float& v) {
  if (periodic) {
    const float length = hi - lo;
    if (x >= hi) x -= length;
    if (x < lo) x += length;
    if (!(x < hi)) x = lo;
    return;
  }
  if (x <= lo) {
    x = lo;
    if (v < 0) v = -v * 0.0f;
  } else if (x >= hi) {
    x = hi;
    if (v > 0) v = -v * 0.0f;
  }
}

// LimitApproachToSurfaces (physical_passes.cc): cuts v so that a step of dt from x comes
// no nearer than r0 / 2 to any wall or obstacle, cutting only the velocity relative to it.
__device__ void LimitApproachToSurfaces(const SphConstants& c, const Surfaces& s, F3 x, float dt,
                                        F3& v) {
  const float r0 = c.contact_range;
  // A moving surface closes in at up to its own speed: the CPU's max over the obstacles of
  // |v| + |u|, which is |v| + the largest |u| (rounding is monotonic) and |v| when all are static.
  const float speed = sqrtf(Norm2(v));
  const float closing = speed + s.obstacle_speed;
  const float reach = 0.5f * r0 + (speed < closing ? closing : speed) * dt;  // std::max
  for (int sweep = 0; sweep < 4; ++sweep) {
    bool cut = false;
    ForEachSurfaceWithin(c, s, x, reach, [&](float dist, F3 normal, F3 u) {
      const float gap = dist - 0.5f * r0;
      const float allowed = -(gap < 0.0f ? 0.0f : gap) / dt;  // std::max(gap, 0)
      const float vn = Dot({v.x - u.x, v.y - u.y, v.z - u.z}, normal);
      if (vn < allowed) {
        const float k = allowed - vn;
        v.x += k * normal.x, v.y += k * normal.y, v.z += k * normal.z;
        cut = true;
      }
    });
    if (!cut) break;
  }
}

// x += v dt, then the last-resort clamp to the domain (CollideWithDomainWalls, damping 0); stores
// x and v of particle i.
__device__ void MoveAndStore(const SphConstants& c, const Surfaces& s, Fluid f, uint32_t i, F3 x,
                             F3 v, float dt) {
  float xs[3] = {x.x + v.x * dt, x.y + v.y * dt, x.z + v.z * dt};
  float vs[3] = {v.x, v.y, v.z};
  for (int a = 0; a < 3; ++a) {
    CollideWithWall(c.domain_lo[a], c.domain_hi[a], s.periodic[a], xs[a], vs[a]);
  }
  f.x[i] = xs[0], f.y[i] = xs[1], f.z[i] = xs[2];
  f.vx[i] = vs[0], f.vy[i] = vs[1], f.vz[i] = vs[2];
}

// The kernels' views of a pipeline's arrays (PhysicalArrays, physical_arrays.cuh). Only wcsph
// keeps p / rho^2 and the walls' pressures; dfsph passes null and a scratch array for them.
template <class Arrays>
Fluid FluidOf(Arrays& a, float* p_over_rho2) {
  return {a.x.data(),  a.y.data(),  a.z.data(),       a.vx.data(),       a.vy.data(),
          a.vz.data(), a.id.data(), a.density.data(), a.pressure.data(), a.ax.data(),
          a.ay.data(), a.az.data(), p_over_rho2};
}
template <class Arrays>
Boundary BoundaryOf(Arrays& a, float* pressure, float* p_over_rho2) {
  return {a.bx.data(), a.by.data(),   a.bz.data(),   a.bvolume.data(), a.bno_slip.data(),
          pressure,    p_over_rho2,   a.bvx.data(),  a.bvy.data(),     a.bvz.data(),
          a.nb,        a.moving.ux(), a.moving.uy(), a.moving.uz()};
}
template <class Arrays>
Surfaces SurfacesOf(const Arrays& a) {
  Surfaces s{a.spheres.data(), a.sphere_count, a.boxes.data(), a.box_count, {}, a.obstacle_speed};
  for (int k = 0; k < 3; ++k) s.periodic[k] = a.periodic[k];
  return s;
}

}  // namespace
}  // namespace dysa::cuda::sph
