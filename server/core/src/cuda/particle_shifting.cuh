// Particle shifting (solvers/physical/particle_shifting.h) as a CUDA kernel: the CPU pass's
// sums in the same order with the same operations, so the GPU's step stays the CPU's bit for bit.
#pragma once

#include <cstdint>

#include "cuda/device_grid.cuh"
#include "cuda/sph_kernels.cuh"

namespace dysa::cuda::sph {
namespace {

// shift_i = -A h |v_i| grad C_i (m/s), 0 where div r_i < free_surface. coefficient: A h (m).
__global__ void ParticleShiftingKernel(DeviceGrid fluid_grid, DeviceGrid boundary_grid, Fluid f,
                                       Boundary b, SphConstants c, float coefficient,
                                       float free_surface, float* sx, float* sy, float* sz,
                                       uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const int3 cell = fluid_grid.SortedCell(i);
  const F3 x{f.x[i], f.y[i], f.z[i]};
  F3 concentration{0, 0, 0};
  float divergence = 0;
  ForEachWithin(fluid_grid, {f.x, f.y, f.z}, cell, x, c.support, [&](uint32_t j, F3 xij, float r) {
    const float g = GradFactor(r, c);
    const F3 grad{xij.x * g, xij.y * g, xij.z * g};
    const float v = c.mass / f.density[j];
    concentration.x += v * grad.x, concentration.y += v * grad.y, concentration.z += v * grad.z;
    divergence -= v * Dot(xij, grad);
  });
  ForEachWithin(boundary_grid, {b.x, b.y, b.z}, cell, x, c.support,
                [&](uint32_t k, F3 xib, float r) {
                  const float g = GradFactor(r, c);
                  const F3 grad{xib.x * g, xib.y * g, xib.z * g};
                  const float v = b.volume[k];
                  concentration.x += v * grad.x, concentration.y += v * grad.y;
                  concentration.z += v * grad.z;
                  divergence -= v * Dot(xib, grad);
                });
  const float scale = -(coefficient * sqrtf(Norm2({f.vx[i], f.vy[i], f.vz[i]})));
  const bool surface = divergence < free_surface;
  sx[i] = surface ? 0.0f : scale * concentration.x;
  sy[i] = surface ? 0.0f : scale * concentration.y;
  sz[i] = surface ? 0.0f : scale * concentration.z;
}

}  // namespace
}  // namespace dysa::cuda::sph
