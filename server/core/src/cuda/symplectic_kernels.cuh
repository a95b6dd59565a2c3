// wcsph's predictor-corrector (solvers/wcsph/symplectic.h) as CUDA kernels: PredictHalfStep and
// CorrectStep of symplectic.cc with the same operations in the same order, so that the GPU's
// step stays the CPU's bit for bit where the force passes are.
#pragma once

#include <cstdint>

#include "cuda/sph_kernels.cuh"

namespace dysa::cuda::sph {
namespace {

// The state at the step's start: x^n, v^n and the carried density rho^n, in the particles'
// current order (the corrector's sort permutes them with the particles).
struct StepStart {
  float *x, *y, *z, *vx, *vy, *vz, *density;
};

// The particle shifting's displacement rate (m/s) per particle; null when it is off.
struct Shift {
  const float *x = nullptr, *y = nullptr, *z = nullptr;
};

// Stores x (one axis at a time through the last-resort clamp, which may cut v) of particle i.
__device__ void ClampAndStorePosition(const SphConstants& c, const Surfaces& s, Fluid f, uint32_t i,
                                      float (&xs)[3], float (&vs)[3]) {
  for (int a = 0; a < 3; ++a) {
    CollideWithWall(c.domain_lo[a], c.domain_hi[a], s.periodic[a], xs[a], vs[a]);
  }
  f.x[i] = xs[0], f.y[i] = xs[1], f.z[i] = xs[2];
}

// x^(n+1/2) = x^n + dt/2 v^n (the drift cut by the contact), v^(n+1/2) = v^n + dt/2 a^n,
// rho^(n+1/2) = rho^n + dt/2 (D rho / Dt)^n; keeps x^n, v^n, rho^n in `start`.
__global__ void PredictKernel(Fluid f, SphConstants c, Surfaces s, StepStart start, float* carried,
                              const float* rate, float half, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const F3 x{f.x[i], f.y[i], f.z[i]};
  const F3 v{f.vx[i], f.vy[i], f.vz[i]};
  start.x[i] = x.x, start.y[i] = x.y, start.z[i] = x.z;
  start.vx[i] = v.x, start.vy[i] = v.y, start.vz[i] = v.z;
  start.density[i] = carried[i];
  F3 drift = v;
  LimitApproachToSurfaces(c, s, x, half, drift);
  float xs[3] = {x.x + drift.x * half, x.y + drift.y * half, x.z + drift.z * half};
  float ds[3] = {drift.x, drift.y, drift.z};
  ClampAndStorePosition(c, s, f, i, xs, ds);
  f.vx[i] = v.x + f.ax[i] * half, f.vy[i] = v.y + f.ay[i] * half, f.vz[i] = v.z + f.az[i] * half;
  carried[i] = BoundCarriedDensity(c, carried[i] + rate[i] * half);
  f.density[i] = carried[i];
}

// v^(n+1) = v^n + dt a^(n+1/2), x^(n+1) = x^n + dt (v^n + v^(n+1)) / 2 (each cut by the contact
// from x^n, plus the particle shifting's `shift` where it is on), rho^(n+1) = rho^n (2 - e) /
// (2 + e), e = -(D rho / Dt)^(n+1/2) dt / rho^(n+1/2).
__global__ void CorrectKernel(Fluid f, SphConstants c, Surfaces s, StepStart start, float* carried,
                              const float* rate, Shift shift, float dt, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const F3 x0{start.x[i], start.y[i], start.z[i]};
  const F3 v0{start.vx[i], start.vy[i], start.vz[i]};
  F3 v{v0.x + f.ax[i] * dt, v0.y + f.ay[i] * dt, v0.z + f.az[i] * dt};
  LimitApproachToSurfaces(c, s, x0, dt, v);
  F3 drift{(v0.x + v.x) * 0.5f, (v0.y + v.y) * 0.5f, (v0.z + v.z) * 0.5f};
  if (shift.x != nullptr) drift.x += shift.x[i], drift.y += shift.y[i], drift.z += shift.z[i];
  LimitApproachToSurfaces(c, s, x0, dt, drift);
  float xs[3] = {x0.x + drift.x * dt, x0.y + drift.y * dt, x0.z + drift.z * dt};
  float vs[3] = {v.x, v.y, v.z};
  ClampAndStorePosition(c, s, f, i, xs, vs);
  f.vx[i] = vs[0], f.vy[i] = vs[1], f.vz[i] = vs[2];
  const float e = -rate[i] * dt / carried[i];
  carried[i] = BoundCarriedDensity(c, start.density[i] * (2.0f - e) / (2.0f + e));
  f.density[i] = carried[i];
}

}  // namespace
}  // namespace dysa::cuda::sph
