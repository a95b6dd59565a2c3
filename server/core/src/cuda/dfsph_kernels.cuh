// The dfsph solver's passes as CUDA kernels (dfsph_pipeline.cu launches them), each the CPU code
// of solvers/dfsph/bender_koschier_solver.cc and pressure_boundary.cc with the same name and the
// same operations in the same order (dfsph_pipeline.h says where the GPU differs).
#pragma once

#include <cuda_runtime.h>

#include <cstdint>

#include "cuda/device_grid.cuh"
#include "cuda/gpu_types.h"
#include "cuda/sph_kernels.cuh"

namespace dysa::cuda {
// Each file that includes this gets its own copy of these kernels.
namespace {

using namespace sph;  // NOLINT: the shared half of these kernels

// The largest density error, as a fraction of rho0, one iteration of the density solve
// corrects (kMaxCorrection in bender_koschier_solver.cc).
constexpr float kMaxCorrection = 0.05f;
// The signed corrections' step (kSignedStep there).
constexpr float kSignedStep = 0.5f;

// m, the domain's length along each periodic axis, 0 along the others (Model::MinimumImage).
struct Periods {
  float length[3];
};

// The pair lists hold only the other particle's index (4 bytes a pair, not 16 with grad W): the
// solves sweep them a dozen times a step, mostly moving bytes, so each sweep recomputes grad W
// from the positions, which stay put from the density pass to the integration. The
// recomputation repeats the density pass's float operations in its order, so grad W has the
// same bits as the one the density pass summed (and the CPU stores).

// What PairGradW needs of a grid (DeviceGrid::layout) to redo ForEachWithin's x_ij.
struct Seams {
  bool periodic[3];
  float period[3];  // m
};
inline Seams SeamsOf(const DeviceGrid& grid) {
  Seams seams;
  for (int a = 0; a < 3; ++a) {
    seams.periodic[a] = grid.layout.periodic[a];
    seams.period[a] = grid.layout.period[a];
  }
  return seams;
}

// The shift along one axis that ForEachNeighborRun added to x_i for the run that held x_j: 0,
// or +-L where the pair straddles a periodic axis's seam (the exact float the grid added, so
// x_i + shift rounds as there). The grid shifts only from an edge cell to the opposite edge's
// cell, and the density pass lists a pair only within the support, which is at most about a
// third of L (NeighborGrid: 3 or more cells a periodic axis, none narrower than the support
// but for 1e-6): so |x_i + shift - x_j| < L/3 for the grid's shift and > 2L/3 for the two
// others, and x_i - x_j beyond +-L/2 tells which it was.
__device__ float SeamShift(bool periodic, float period, float xi, float xj) {
  if (!periodic) return 0.0f;
  const float d = xi - xj;
  if (d < -0.5f * period) return period;
  if (d > 0.5f * period) return -period;
  return 0.0f;
}

// GradW (sph_loops.h) at offset x_ij and distance r: x_ij dW/dr / r, zero at r = 0 (1/m^4).
__device__ F3 GradW(F3 xij, float r, const SphConstants& c) {
  const float gf = GradFactor(r, c);
  return {xij.x * gf, xij.y * gf, xij.z * gf};
}

// grad W(x_i - x_j) of a listed pair, as the density pass computed it: ForEachWithin's
// q = x_i + shift, x_ij = q - x_j, r = sqrt(|x_ij|^2) (Norm2's order), then GradW.
__device__ F3 PairGradW(F3 xi, F3 xj, const Seams& seams, const SphConstants& c) {
  const F3 q{xi.x + SeamShift(seams.periodic[0], seams.period[0], xi.x, xj.x),
             xi.y + SeamShift(seams.periodic[1], seams.period[1], xi.y, xj.y),
             xi.z + SeamShift(seams.periodic[2], seams.period[2], xi.z, xj.z)};
  const F3 xij{q.x - xj.x, q.y - xj.y, q.z - xj.z};
  return GradW(xij, sqrtf(Norm2(xij)), c);
}

// The per-particle arrays of the solves (Work in bender_koschier_solver.cc) and the lists.
struct Solver {
  float *alpha, *kappa, *error, *kappa_sum;
  const uint32_t *fluid_begin, *wall_begin;
  uint32_t *fluid_pairs, *wall_pairs;  // the other particle (fluid) or sample (wall) of each pair
  // The fluid's positions packed with kappa / rho of the solve's current iteration (KappaOverRho:
  // x, y, z, kappa_j / rho_j): a fluid pair of the solves loads the other particle's x_j (and
  // kappa_j / rho_j) in one 16-byte load. The same floats as f.x, f.y, f.z.
  float4* packed;
  Seams fluid_seams, wall_seams;  // of the fluid's and the boundary's grids
  // The walls' fluid neighbours (dfsph::BoundaryNeighbors), b's in [bn_begin[b], bn_begin[b+1]).
  const uint32_t* bn_begin;
  const uint32_t* bn_fluid;
  float* bn_weight;
  float* hydrostatic;  // Pa
  float* kappa_b;      // kappa_b / rho of the current iteration
};

// The counts of pairs at distance > 0 within the support, fluid and wall, of each particle, and
// the packed positions of the step (Solver::packed).
__global__ void CountPairsKernel(DeviceGrid grid, DeviceGrid bgrid, Fluid f, Boundary b,
                                 SphConstants c, uint32_t* fluid_count, uint32_t* wall_count,
                                 float4* packed, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const int3 cell = grid.SortedCell(i);
  const F3 x{f.x[i], f.y[i], f.z[i]};
  packed[i] = make_float4(x.x, x.y, x.z, 0.0f);
  uint32_t fluid = 0, wall = 0;
  ForEachWithin(grid, {f.x, f.y, f.z}, cell, x, c.support, [&](uint32_t, F3, float r) {
    if (r > 0) ++fluid;
  });
  ForEachWithin(bgrid, {b.x, b.y, b.z}, cell, x, c.support, [&](uint32_t, F3, float r) {
    if (r > 0) ++wall;
  });
  fluid_count[i] = fluid;
  wall_count[i] = wall;
}

// DensityAndFactor: rho_i, alpha_i and the pairs (their indices; the solves recompute grad W
// with PairGradW, which repeats what ForEachWithin and GradW do here).
__global__ void DensityAndFactorKernel(DeviceGrid grid, DeviceGrid bgrid, Fluid f, Boundary b,
                                       Solver s, SphConstants c, uint32_t* wall_owner, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const int3 cell = grid.SortedCell(i);
  const F3 x{f.x[i], f.y[i], f.z[i]};
  const float rho0 = c.psi_scale;
  float fluid = 0, squares = 0;
  F3 grad{0, 0, 0};
  uint32_t k = s.fluid_begin[i];
  ForEachWithin(grid, {f.x, f.y, f.z}, cell, x, c.support, [&](uint32_t j, F3 xij, float r) {
    fluid += KernelW(r, c);
    const F3 g = GradW(xij, r, c);
    if (r > 0) s.fluid_pairs[k++] = j;
    const F3 mg{c.mass * g.x, c.mass * g.y, c.mass * g.z};
    grad.x += mg.x, grad.y += mg.y, grad.z += mg.z;
    squares += Norm2(mg);
  });
  float wall = 0;
  uint32_t kw = s.wall_begin[i];
  ForEachWithin(bgrid, {b.x, b.y, b.z}, cell, x, c.support, [&](uint32_t o, F3 xib, float r) {
    wall += b.volume[o] * KernelW(r, c);
    const F3 g = GradW(xib, r, c);
    if (r > 0) {
      wall_owner[kw] = i;
      s.wall_pairs[kw++] = o;
    }
    const float psi = rho0 * b.volume[o];
    grad.x += psi * g.x, grad.y += psi * g.y, grad.z += psi * g.z;
  });
  const float rho = (c.mass * fluid + rho0 * wall) * c.density_scale;
  f.density[i] = rho;
  const float denominator = Norm2(grad) + squares;
  s.alpha[i] = denominator > 1e-6f * rho * rho / (c.support * c.support) ? rho / denominator : 0.0f;
}

// The walls' Shepard weights and hydrostatic pressure (ListBoundaryNeighbors).
__global__ void BoundaryWeightsKernel(Fluid f, Boundary b, Solver s, SphConstants c, Periods period,
                                      float gravity) {
  const uint32_t o = blockIdx.x * blockDim.x + threadIdx.x;
  if (o >= b.n) return;
  float sum = 0, head = 0;
  for (uint32_t k = s.bn_begin[o]; k < s.bn_begin[o + 1]; ++k) {
    const uint32_t i = s.bn_fluid[k];
    float d[3] = {b.x[o] - f.x[i], b.y[o] - f.y[i], b.z[o] - f.z[i]};
    for (int a = 0; a < 3; ++a) {  // Model::MinimumImage
      const float length = period.length[a];
      if (length == 0) continue;
      if (d[a] > length / 2) d[a] -= length;
      if (d[a] < -length / 2) d[a] += length;
    }
    const float w = KernelW(sqrtf(Norm2({d[0], d[1], d[2]})), c);
    s.bn_weight[k] = w;
    sum += w;
    head += w * f.density[i] * d[1];
  }
  const float inv = sum > 0 ? 1 / sum : 0.0f;
  for (uint32_t k = s.bn_begin[o]; k < s.bn_begin[o + 1]; ++k) s.bn_weight[k] *= inv;
  const float hydrostatic = gravity * head * inv;
  s.hydrostatic[o] = hydrostatic < 0.0f ? 0.0f : hydrostatic;  // std::max(., 0)
  s.kappa_b[o] = 0;
}

__global__ void HydrostaticAccelerationKernel(Fluid f, Boundary b, Solver s, SphConstants c,
                                              float mu, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const float4 pi = s.packed[i];
  const F3 xi{pi.x, pi.y, pi.z};
  F3 sum{0, 0, 0};
  for (uint32_t k = s.wall_begin[i]; k < s.wall_begin[i + 1]; ++k) {
    const uint32_t o = s.wall_pairs[k];
    const F3 g = PairGradW(xi, {b.x[o], b.y[o], b.z[o]}, s.wall_seams, c);
    const float w = b.volume[o] * s.hydrostatic[o];
    sum.x += w * g.x, sum.y += w * g.y, sum.z += w * g.z;
  }
  const float rho = f.density[i];
  const float scale = -c.psi_scale / (rho * rho * mu);
  f.ax[i] = scale * sum.x, f.ay[i] = scale * sum.y, f.az[i] = scale * sum.z;
}

// D rho_i / Dt over the step's pairs (DensityRate).
__device__ float DensityRate(const Fluid& f, const Boundary& b, const Solver& s,
                             const SphConstants& c, uint32_t i) {
  const float4 pi = s.packed[i];
  const F3 xi{pi.x, pi.y, pi.z};
  const F3 v{f.vx[i], f.vy[i], f.vz[i]};
  float rate = 0;
  for (uint32_t k = s.fluid_begin[i]; k < s.fluid_begin[i + 1]; ++k) {
    const uint32_t j = s.fluid_pairs[k];
    const float4 pj = s.packed[j];
    const F3 g = PairGradW(xi, {pj.x, pj.y, pj.z}, s.fluid_seams, c);
    rate += c.mass * Dot({v.x - f.vx[j], v.y - f.vy[j], v.z - f.vz[j]}, g);
  }
  for (uint32_t k = s.wall_begin[i]; k < s.wall_begin[i + 1]; ++k) {
    const uint32_t o = s.wall_pairs[k];
    const F3 g = PairGradW(xi, {b.x[o], b.y[o], b.z[o]}, s.wall_seams, c);
    // A moving obstacle's samples carry its velocity v_b: Psi_b (v_i - v_b) . grad W.
    rate += c.psi_scale * b.volume[o] * Dot(RelativeToSample(b, v, o), g);
  }
  return rate;
}

// StartWarmStart's per-particle part: kappa_i from what the solve applied last step.
__global__ void WarmStartKernel(Fluid f, Boundary b, Solver s, SphConstants c, float* carried,
                                float dt, float scale, float bound, bool density_solve,
                                unsigned long long* any, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const float rho0 = c.psi_scale;
  float kappa = 0;
  if (carried[i] > 0) {
    const float rate = DensityRate(f, b, s, c, i);
    const bool compressing =
        density_solve ? f.density[i] + dt * rate > rho0 : rate > 0 && f.density[i] >= rho0;
    if (compressing) {
      const float warm = scale * carried[i], cap = bound * s.alpha[i];
      kappa = cap < warm ? cap : warm;  // std::min
    }
  }
  s.kappa[i] = kappa;
  carried[i] = 0;
  if (kappa > 0) *any = 1;  // every writer writes the same value
}

// TakenBack (bender_koschier_solver.cc): what a signed correction corrects.
__device__ inline float TakenBack(float difference, float kappa, float per_density) {
  if (difference > 0.0f) return difference;
  return kappa < 0.0f ? -kappa / per_density : 0.0f;
}

// One iteration's error and kappa with signed corrections (the CPU's signed branches): the solve's
// total, applied, stays >= 0.
__device__ inline void SignedErrorAndKappa(Fluid f, Boundary b, Solver s, SphConstants c, float dt,
                                           float inv_dt_power, bool density_solve,
                                           const float* applied, uint32_t i) {
  const float rho0 = c.psi_scale;
  const float floor = -applied[i];
  if (density_solve) {
    const float difference = f.density[i] + dt * DensityRate(f, b, s, c, i) - rho0;
    const float cap = kMaxCorrection * rho0;
    const float bounded = difference < -cap ? -cap : (cap < difference ? cap : difference);
    const float raw = kSignedStep * bounded * inv_dt_power * s.alpha[i];
    const float kappa = raw < floor ? floor : raw;  // std::max(raw, floor)
    s.kappa[i] = kappa;
    s.error[i] = TakenBack(difference, kappa, kSignedStep * inv_dt_power * s.alpha[i]);
  } else {
    const float rate = f.density[i] >= rho0 ? DensityRate(f, b, s, c, i) : 0.0f;
    const float raw = kSignedStep * rate * s.alpha[i] * inv_dt_power;
    const float kappa = raw < floor ? floor : raw;
    s.kappa[i] = kappa;
    s.error[i] = TakenBack(rate, kappa, kSignedStep * s.alpha[i] * inv_dt_power);
  }
}

// One iteration's error and kappa: the divergence solve (density_solve false) or the density
// solve; with signed corrections where `applied` is given.
__global__ void SolveErrorKernel(Fluid f, Boundary b, Solver s, SphConstants c, float dt,
                                 float inv_dt_power, bool density_solve, const float* applied,
                                 uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  if (applied) {
    SignedErrorAndKappa(f, b, s, c, dt, inv_dt_power, density_solve, applied, i);
    return;
  }
  const float rho0 = c.psi_scale;
  if (density_solve) {
    const float predicted = f.density[i] + dt * DensityRate(f, b, s, c, i);
    const float difference = predicted - rho0;
    const float excess = difference < 0.0f ? 0.0f : difference;  // std::max(., 0)
    s.error[i] = excess;
    const float cap = kMaxCorrection * rho0;
    s.kappa[i] = (cap < excess ? cap : excess) * inv_dt_power * s.alpha[i];
  } else {
    float rate = 0;
    if (f.density[i] >= rho0) {
      const float r = DensityRate(f, b, s, c, i);
      rate = r < 0.0f ? 0.0f : r;  // std::max(r, 0)
    }
    s.error[i] = rate;
    s.kappa[i] = rate * s.alpha[i] * inv_dt_power;
  }
}

// kappa_j / rho_j into the packed positions' fourth float, which ApplyKappa reads with x_j.
__global__ void KappaOverRhoKernel(Fluid f, Solver s, uint32_t n) {
  const uint32_t j = blockIdx.x * blockDim.x + threadIdx.x;
  if (j < n) s.packed[j].w = s.kappa[j] / f.density[j];
}

// ExtrapolateKappa: kappa_b = sum_i w_bi kappa_i / rho_i.
__global__ void ExtrapolateKappaKernel(Solver s, uint32_t nb) {
  const uint32_t o = blockIdx.x * blockDim.x + threadIdx.x;
  if (o >= nb) return;
  float kappa = 0;
  for (uint32_t k = s.bn_begin[o]; k < s.bn_begin[o + 1]; ++k) {
    kappa += s.bn_weight[k] * s.packed[s.bn_fluid[k]].w;
  }
  s.kappa_b[o] = kappa;
}

// ApplyKappa's per-particle part (s.packed's fourth float holds kappa / rho).
__global__ void ApplyKappaKernel(Fluid f, Boundary b, Solver s, SphConstants c, float dt,
                                 float* applied, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const float4 pi = s.packed[i];
  const F3 xi{pi.x, pi.y, pi.z};
  const float ki = pi.w;
  F3 fluid{0, 0, 0}, wall{0, 0, 0};
  for (uint32_t k = s.fluid_begin[i]; k < s.fluid_begin[i + 1]; ++k) {
    const float4 pj = s.packed[s.fluid_pairs[k]];
    const F3 g = PairGradW(xi, {pj.x, pj.y, pj.z}, s.fluid_seams, c);
    const float w = ki + pj.w;
    fluid.x += w * g.x, fluid.y += w * g.y, fluid.z += w * g.z;
  }
  for (uint32_t k = s.wall_begin[i]; k < s.wall_begin[i + 1]; ++k) {
    const uint32_t o = s.wall_pairs[k];
    const F3 g = PairGradW(xi, {b.x[o], b.y[o], b.z[o]}, s.wall_seams, c);
    const float w = b.volume[o] * (ki + s.kappa_b[o]);
    wall.x += w * g.x, wall.y += w * g.y, wall.z += w * g.z;
  }
  f.vx[i] -= dt * (c.mass * fluid.x + c.psi_scale * wall.x);
  f.vy[i] -= dt * (c.mass * fluid.y + c.psi_scale * wall.y);
  f.vz[i] -= dt * (c.mass * fluid.z + c.psi_scale * wall.z);
  s.kappa_sum[i] += s.kappa[i] * dt;
  applied[i] += s.kappa[i];
}

__global__ void ScaleKernel(float* values, float scale, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) values[i] *= scale;
}

__global__ void AddGravityKernel(Fluid f, float gravity, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  f.ax[i] += 0.0f, f.ay[i] += gravity, f.az[i] += 0.0f;
}

__global__ void PredictVelocityKernel(Fluid f, float dt, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  f.vx[i] += f.ax[i] * dt, f.vy[i] += f.ay[i] * dt, f.vz[i] += f.az[i] * dt;
}

__global__ void PressureKernel(Fluid f, Solver s, float scale, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) f.pressure[i] = scale * s.kappa_sum[i] * f.density[i];
}

// IntegratePositions: the speed limit, the wall contact, x += v dt. A ghost (ghost non-null and
// ghost[i] != 0) is limited but counted by its owner.
__global__ void IntegrateKernel(Fluid f, SphConstants c, Surfaces surfaces, float dt, float limit,
                                const uint8_t* ghost, unsigned long long* limited, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  F3 v{f.vx[i], f.vy[i], f.vz[i]};
  const float speed2 = Norm2(v);
  if (speed2 > limit * limit) {
    const float k = limit / sqrtf(speed2);
    v.x *= k, v.y *= k, v.z *= k;
    // An integer count: the same whatever the order.
    if (!(ghost && ghost[i])) atomicAdd(limited, 1ull);
  }
  const F3 x{f.x[i], f.y[i], f.z[i]};
  LimitApproachToSurfaces(c, surfaces, x, dt, v);
  MoveAndStore(c, surfaces, f, i, x, v, dt);
}

// |v_i|^2, 0 for a ghost (ghost non-null and ghost[i] != 0): MaxSpeed's input (the CPU's
// maximum starts at 0).
__global__ void SpeedSquaredKernel(Fluid f, const uint8_t* ghost, float* speed2, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  speed2[i] = (ghost && ghost[i]) ? 0.0f : Norm2({f.vx[i], f.vy[i], f.vz[i]});
}

__global__ void OwnerCountKernel(const uint32_t* keys, uint32_t* count, uint32_t n) {
  const uint32_t k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k < n) atomicAdd(&count[keys[k]], 1u);  // integer counts: order-independent
}

}  // namespace
}  // namespace dysa::cuda
