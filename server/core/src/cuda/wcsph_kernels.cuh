// The wcsph solver's passes as CUDA kernels (wcsph_pipeline.cu launches them), each the CPU pass
// of solvers/wcsph/becker_teschner_solver.cc with the same name and the same operations in the
// same order. One thread per fluid (or boundary) particle, gathering only.
#pragma once

#include <cstdint>

#include "cuda/device_grid.cuh"
#include "cuda/sph_kernels.cuh"
#include "cuda/symplectic_kernels.cuh"

namespace dysa::cuda::sph {
namespace {
// The carried density's start: max(summation density, rho0) (InitialDensity).
__global__ void InitialDensityKernel(DeviceGrid fluid_grid, DeviceGrid boundary_grid, Fluid f,
                                     Boundary b, SphConstants c, float* carried, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const int3 cell = fluid_grid.SortedCell(i);
  const F3 x{f.x[i], f.y[i], f.z[i]};
  float fluid = 0;
  ForEachWithin(fluid_grid, {f.x, f.y, f.z}, cell, x, c.support,
                [&](uint32_t, F3, float r) { fluid += KernelW(r, c); });
  float wall = 0;
  ForEachWithin(boundary_grid, {b.x, b.y, b.z}, cell, x, c.support,
                [&](uint32_t k, F3, float r) { wall += b.volume[k] * KernelW(r, c); });
  const float rho = (c.mass * fluid + c.psi_scale * wall) * c.density_scale;
  const float rho0 = float(c.rest_density);
  carried[i] = rho > rho0 ? rho : rho0;
}

// What the interaction sweep reads of each neighbour, packed so that a candidate costs one
// 16-byte load and a neighbour one more: (x, y, z, p / rho^2) and (vx, vy, vz, carried density).
// The same floats as the separate arrays: the sums do not change by a bit.
struct PackedFluid {
  float4* position;  // m, and Pa m^6/kg^2
  float4* velocity;  // m/s, and kg/m^3
};

// The density, pressure (Tait, in double as the CPU) and p / rho^2 of the carried density
// (ComputePressure), and the packed copy of the neighbours' state the sweep reads.
__global__ void PressureKernel(Fluid f, SphConstants c, const float* carried, PackedFluid packed,
                               uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const float rho_i = carried[i];
  f.density[i] = rho_i;
  const double ratio = double(rho_i) / c.rest_density;
  const double pressure = c.stiffness * (pow(ratio, 7.0) - 1);
  f.pressure[i] = float(pressure > 0 ? pressure : 0);
  f.p_over_rho2[i] = f.pressure[i] / (f.density[i] * f.density[i]);
  packed.position[i] = make_float4(f.x[i], f.y[i], f.z[i], f.p_over_rho2[i]);
  packed.velocity[i] = make_float4(f.vx[i], f.vy[i], f.vz[i], rho_i);
}

// ForEachWithin over the packed positions: visit(j, x_ij, r, position_j), the same candidates,
// order and arithmetic.
template <class Visit>
__device__ void ForEachPackedWithin(const DeviceGrid& grid, const float4* __restrict__ position,
                                    int3 cell, F3 p, float support, Visit&& visit) {
  const float support2 = support * support;
  grid.ForEachNeighborRun(cell, [&](uint32_t begin, uint32_t end, float sx, float sy, float sz) {
    const F3 q{p.x + sx, p.y + sy, p.z + sz};
    for (uint32_t j = begin; j < end; ++j) {
      const float4 pj = position[j];
      const F3 xij{q.x - pj.x, q.y - pj.y, q.z - pj.z};
      const float r2 = Norm2(xij);
      if (r2 < support2) visit(j, xij, sqrtf(r2), pj);
    }
  });
}

// Each boundary particle's pressure extrapolated from the fluid, and its p / rho^2 (its density
// from its pressure through the inverse Tait equation) (ComputeBoundaryPressure). The candidates
// come from `packed` (one 16-byte load each, the same floats as f.x, f.y, f.z); a neighbour's
// pressure and density are read only within the support. A wall particle without pressure (dry,
// or next to a splash) skips the inverse Tait equation: rho_b = rho0 and p_b / rho_b^2 = 0
// exactly, what the double pow would give.
__global__ void BoundaryPressureKernel(DeviceGrid fluid_grid, DeviceGrid boundary_grid, Fluid f,
                                       Boundary b, SphConstants c, PackedFluid packed,
                                       float gravity) {
  const uint32_t k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k >= b.n) return;
  const F3 x{b.x[k], b.y[k], b.z[k]};
  const F3 g{0, gravity, 0};
  float weights = 0, weighted = 0;
  ForEachPackedWithin(fluid_grid, packed.position, boundary_grid.SortedCell(k), x, c.support,
                      [&](uint32_t j, F3 xbf, float r, float4) {
                        const float w = KernelW(r, c);
                        weights += w;
                        weighted += (f.pressure[j] + f.density[j] * Dot(g, xbf)) * w;
                      });
  const float pressure = weights > 0 ? weighted / weights : 0.0f;
  b.pressure[k] = pressure > 0 ? pressure : 0.0f;
  if (b.pressure[k] == 0) {
    b.p_over_rho2[k] = 0;
    return;
  }
  const double pb = b.pressure[k];
  const double rho = c.rest_density * pow(pb / c.stiffness + 1, 1 / 7.0);
  b.p_over_rho2[k] = float(pb / (rho * rho));
}

// The step's one sweep over each particle's neighbours (ComputeInteractions): D rho / Dt of the
// continuity equation with its diffusion (hydrostatic: -rho0 g_y / c0^2), and the acceleration:
// gravity, the pressure force, the viscosity and the no-slip walls' viscosity, and the artificial
// viscosity over approaching fluid pairs and no-slip wall pairs, each sum in its own
// accumulator in the grid's order.
// The fluid neighbours come from `packed` (PressureKernel's copy): the density the viscosity
// divides by is the carried one, as f.density is.
__global__ void InteractionKernel(DeviceGrid fluid_grid, DeviceGrid boundary_grid, Fluid f,
                                  Boundary b, SphConstants c, PackedFluid packed, float* rate,
                                  float hydrostatic, float gravity, bool viscosity,
                                  bool wall_viscosity, bool artificial, bool wall_artificial,
                                  uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const int3 cell = fluid_grid.SortedCell(i);
  const float4 xi = packed.position[i];
  const float4 vi = packed.velocity[i];
  const F3 x{xi.x, xi.y, xi.z};
  const F3 v{vi.x, vi.y, vi.z};
  const float rho_i = vi.w;
  const float pi = xi.w;
  const float4* __restrict__ velocity = packed.velocity;
  float divergence = 0, diffused = 0;
  F3 fluid{0, 0, 0}, viscous{0, 0, 0}, art{0, 0, 0};
  ForEachPackedWithin(
      fluid_grid, packed.position, cell, x, c.support, [&](uint32_t j, F3 xij, float r, float4 pj) {
        const float g = GradFactor(r, c);
        const F3 grad{xij.x * g, xij.y * g, xij.z * g};
        const float s = pi + pj.w;
        fluid.x += s * grad.x, fluid.y += s * grad.y, fluid.z += s * grad.z;
        if (r <= 0) return;
        const float4 vj = velocity[j];
        const F3 vij{v.x - vj.x, v.y - vj.y, v.z - vj.z};
        divergence += Dot(vij, grad);
        const float dynamic = vj.w - rho_i - hydrostatic * xij.y;
        diffused += dynamic * Dot({-xij.x, -xij.y, -xij.z}, grad) / (r * r * vj.w);
        if (viscosity) {
          const float sv = Dot(vij, xij) / (vj.w * (r * r + c.eps));
          viscous.x += sv * grad.x, viscous.y += sv * grad.y, viscous.z += sv * grad.z;
        }
        if (artificial) {  // approaching pairs only
          const float vx = Dot(vij, xij);
          if (vx < 0) {
            const float sa = vx / ((rho_i + vj.w) * (r * r + c.eps));
            art.x += sa * grad.x, art.y += sa * grad.y, art.z += sa * grad.z;
          }
        }
      });
  float wall = 0;
  F3 wall_force{0, 0, 0}, wall_viscous{0, 0, 0}, wall_art{0, 0, 0};
  ForEachWithin(
      boundary_grid, {b.x, b.y, b.z}, cell, x, c.support, [&](uint32_t k, F3 xib, float r) {
        const float g = GradFactor(r, c);
        const F3 grad{xib.x * g, xib.y * g, xib.z * g};
        wall += b.volume[k] * Dot(RelativeToSample(b, v, k), grad);
        const float s = b.volume[k] * (pi + b.p_over_rho2[k]);
        wall_force.x += s * grad.x, wall_force.y += s * grad.y, wall_force.z += s * grad.z;
        if (wall_viscosity && b.no_slip[k] && r > 0) {
          const float vx = Dot({v.x - b.vx[k], v.y - b.vy[k], v.z - b.vz[k]}, xib);
          const float sw = b.volume[k] * vx / (r * r + c.eps);
          wall_viscous.x += sw * grad.x, wall_viscous.y += sw * grad.y;
          wall_viscous.z += sw * grad.z;
        }
        if (wall_artificial && b.no_slip[k] && r > 0) {
          const float vx = Dot({v.x - b.vx[k], v.y - b.vy[k], v.z - b.vz[k]}, xib);
          if (vx < 0) {
            const float sa = b.volume[k] * vx / (r * r + c.eps);
            wall_art.x += sa * grad.x, wall_art.y += sa * grad.y, wall_art.z += sa * grad.z;
          }
        }
      });
  rate[i] = c.mass * divergence + c.psi_scale * wall + 2 * c.diffusion * c.mass * diffused;
  F3 a{0.0f - c.gradient_scale * (c.mass * fluid.x + c.psi_scale * wall_force.x),
       gravity - c.gradient_scale * (c.mass * fluid.y + c.psi_scale * wall_force.y),
       0.0f - c.gradient_scale * (c.mass * fluid.z + c.psi_scale * wall_force.z)};
  if (viscosity) AddScaled(a, c.viscosity_scale, viscous);
  if (wall_viscosity) AddScaled(a, c.wall_viscosity_scale, wall_viscous);
  // Only with alpha > 0, as the CPU: with alpha = 0 the step is what it was without the term.
  if (artificial) AddScaled(a, c.artificial_scale, art);
  if (wall_artificial) AddScaled(a, c.wall_artificial_scale, wall_art);
  f.ax[i] = a.x, f.ay[i] = a.y, f.az[i] = a.z;
}

// v += a dt, the wall contact, x += v dt, rho += (D rho / Dt) dt (Integrate in
// becker_teschner_solver.cc).
__global__ void IntegrateKernel(Fluid f, SphConstants c, Surfaces s, float* carried,
                                const float* rate, Shift shift, float dt, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  F3 v{f.vx[i] + f.ax[i] * dt, f.vy[i] + f.ay[i] * dt, f.vz[i] + f.az[i] * dt};
  const F3 x{f.x[i], f.y[i], f.z[i]};
  LimitApproachToSurfaces(c, s, x, dt, v);
  if (shift.x == nullptr) {
    MoveAndStore(c, s, f, i, x, v, dt);
  } else {
    // The shift's displacement too, cut by the contact as the velocity's.
    F3 drift{v.x + shift.x[i], v.y + shift.y[i], v.z + shift.z[i]};
    LimitApproachToSurfaces(c, s, x, dt, drift);
    float xs[3] = {x.x + drift.x * dt, x.y + drift.y * dt, x.z + drift.z * dt};
    float vs[3] = {v.x, v.y, v.z};
    ClampAndStorePosition(c, s, f, i, xs, vs);
    f.vx[i] = vs[0], f.vy[i] = vs[1], f.vz[i] = vs[2];
  }
  carried[i] = BoundCarriedDensity(c, carried[i] + rate[i] * dt);
  f.density[i] = carried[i];
}

}  // namespace
}  // namespace dysa::cuda::sph
