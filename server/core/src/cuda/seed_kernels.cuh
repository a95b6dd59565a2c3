// The seed solver's passes as CUDA kernels (seed_pipeline.h says why they match the CPU bit
// for bit). Each kernel is the CPU pass of solvers/seed/seed_solver.cc with the same name; the
// comments here say only where the GPU differs in how, never in what, it computes. The kernels
// that read the neighbour list are seed_list_kernels.cuh's.
#pragma once

#include <cuda_runtime.h>

#include <cstdint>

#include "cuda/device_buffer.cuh"
#include "cuda/device_grid.cuh"
#include "cuda/gpu_types.h"
#include "cuda/seed_neighbour_list.cuh"
#include "cuda/seed_pipeline.h"

namespace dysa::cuda {
// Each file that includes this gets its own copy of these kernels.
namespace {

struct Particles {
  float *x, *y, *z;     // position, m
  float *vx, *vy, *vz;  // velocity, m/s
  float *px, *py, *pz;  // predicted position, m (after the sort: the grid's points)
  uint32_t* id;
};

// A particle's predicted position and a value its neighbours read in the same pass (the pressure
// factors, then the velocity copy): the list kernels load both of a neighbour from one 32-byte
// sector instead of two.
struct alignas(32) PosValue {
  float4 pos, value;
};

struct Obstacles {
  const SphereObstacle* spheres;
  int sphere_count;
  const BoxObstacle* boxes;
  int box_count;
};

__global__ void ExternalForcesKernel(Particles p, uint32_t n, float dv, float lookahead) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  // Eigen adds the whole vector (0, dv, 0): +0 is added to x and z too (it turns -0 into +0).
  const float vx = p.vx[i] + 0.0f, vy = p.vy[i] + dv, vz = p.vz[i] + 0.0f;
  p.vx[i] = vx;
  p.vy[i] = vy;
  p.vz[i] = vz;
  p.px[i] = p.x[i] + vx * lookahead;
  p.py[i] = p.y[i] + vy * lookahead;
  p.pz[i] = p.z[i] + vz * lookahead;
}

// The unit direction of CoincidentDirection (seed_solver.cc) for two coincident particles.
__device__ void CoincidentDirection(uint32_t id_i, uint32_t id_j, float d[3]) {
  const uint32_t lo = id_i < id_j ? id_i : id_j;
  const uint32_t hi = id_i < id_j ? id_j : id_i;
  uint64_t h = (uint64_t{lo} << 32 | hi) * 0x9E3779B97F4A7C15ull;
  h ^= h >> 29;
  h *= 0xBF58476D1CE4E5B9ull;
  h ^= h >> 32;
  d[0] = float(int(h & 0xFFFF)) - 32767.5f;
  d[1] = float(int((h >> 16) & 0xFFFF)) - 32767.5f;
  d[2] = float(int((h >> 32) & 0xFFFF)) - 32767.5f;
  // Eigen's normalize(): squaredNorm as x^2 + (y^2 + z^2), then a division by its square root.
  const float n2 = d[0] * d[0] + (d[1] * d[1] + d[2] * d[2]);
  if (n2 > 0) {
    const float norm = sqrtf(n2);
    d[0] /= norm;
    d[1] /= norm;
    d[2] /= norm;
  }
  if (!(id_i < id_j)) d[0] = -d[0], d[1] = -d[1], d[2] = -d[2];
}

__device__ float LaneSum(const float v[kLanes]) {
  float s = 0;
#pragma unroll
  for (int l = 0; l < kLanes; ++l) s += v[l];
  return s;
}

struct Densities {
  float *density, *near_density, *pressure, *near_pressure;
};

__device__ float SquaredDistance(float4 pj, float qx, float qy, float qz, float& dx, float& dy,
                                 float& dz) {
  dx = pj.x - qx, dy = pj.y - qy, dz = pj.z - qz;
  return dx * dx + dy * dy + dz * dz;
}

template <bool kNear>
__device__ void StoreDensity(const Densities& d, const SeedConstants& c, uint32_t i, float sum2,
                             float sum3) {
  const float rho = c.mass_spiky2 * sum2;
  d.density[i] = rho;
  d.pressure[i] = (rho - c.rho0) * c.stiffness;
  if (kNear) {
    const float rho_near = c.mass_spiky3 * sum3;
    d.near_density[i] = rho_near;
    d.near_pressure[i] = rho_near * c.near_stiffness;
  }
}

// The pressure force's pair term for 0 < r2 < h2: the pair adds -(dx, dy, dz) times it. f holds
// the neighbour's factors (PressureFactorsKernel).
template <bool kNear>
__device__ float PressureScale(const SeedConstants& c, float r2, float pi, float pni, float4 f) {
  const float r = sqrtf(r2);
  const float q = c.h - r;
  const float inv_r = 1.0f / r;
  float magnitude = c.spiky2_grad * q * (pi * f.x + f.y);
  if (kNear) magnitude += c.spiky3_grad * q * q * (pni * f.x + f.z);
  return magnitude * inv_r;
}

// The rare pairs at distance 0, i itself excluded: a direction from the ids (CoincidentDirection).
// pv: the pressure factors (PressureFactorsKernel).
template <bool kNear>
__device__ void AddCoincidentForces(const DeviceGrid& grid, const float4* pos, const uint32_t* id,
                                    const PosValue* pv, const SeedConstants& c, uint32_t i,
                                    float4 xi, float pi, float pni, float force[3]) {
  grid.ForEachNeighborRun(grid.SortedCell(i), [&](uint32_t begin, uint32_t end, float sx, float sy,
                                                  float sz) {
    for (uint32_t j = begin; j < end; ++j) {
      const float4 pj = pos[j];
      if (j == i || pj.x - (xi.x + sx) != 0 || pj.y - (xi.y + sy) != 0 || pj.z - (xi.z + sz) != 0) {
        continue;
      }
      const float4 f = pv[j].value;
      float magnitude = c.spiky2_grad * c.h * (pi * f.x + f.y);
      if (kNear) magnitude += c.spiky3_grad * c.h * c.h * (pni * f.x + f.z);
      float d[3];
      CoincidentDirection(id[i], id[j], d);
      for (int a = 0; a < 3; ++a) force[a] -= d[a] * magnitude;
    }
  });
}

__device__ void ApplyPressureForce(Particles p, const PosValue* pv, const SeedConstants& c,
                                   uint32_t i, const float force[3]) {
  const float scale = c.mass_dt * 2 * pv[i].value.x;
  p.vx[i] += force[0] * scale;
  p.vy[i] += force[1] * scale;
  p.vz[i] += force[2] * scale;
}

__device__ void ApplyViscosity(Particles p, const SeedConstants& c, uint32_t i, float ax, float ay,
                               float az, float total) {
  const float gain = total * c.viscosity_scale > 1 ? 1 / total : c.viscosity_scale;
  p.vx[i] += ax * gain;
  p.vy[i] += ay * gain;
  p.vz[i] += az * gain;
}

// The grid kernels: each particle scans the candidates of its 27 cells in 8 register lanes.

// The density without a list (DensityListKernel computes it with one).
template <bool kNear>
__global__ void DensityKernel(DeviceGrid grid, const float4* __restrict__ pos, Densities d,
                              SeedConstants c, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const float4 xi = pos[i];
  float sum2[kLanes] = {}, sum3[kLanes] = {};
  grid.ForEachNeighborRun(
      grid.SortedCell(i), [&](uint32_t begin, uint32_t end, float sx, float sy, float sz) {
        const float qx = xi.x + sx, qy = xi.y + sy, qz = xi.z + sz;
        for (uint32_t j = begin; j < end; j += kLanes) {
#pragma unroll
          for (int l = 0; l < kLanes; ++l) {
            if (j + l >= end) break;
            float dx, dy, dz;
            const float r2 = SquaredDistance(__ldg(pos + j + l), qx, qy, qz, dx, dy, dz);
            if (!(r2 < c.h2)) continue;
            const float q = c.h - sqrtf(r2);
            sum2[l] += q * q;
            if (kNear) sum3[l] += q * q * q;
          }
        }
      });
  StoreDensity<kNear>(d, c, i, LaneSum(sum2), LaneSum(sum3));
}

// The per-neighbour factors of the pressure force (PaddedArray in the CPU pass), one float4 per
// particle for one load, beside its position: 0.5 / rho, 0.5 p / rho, 0.5 pn / rho.
__global__ void PressureFactorsKernel(const float4* pos, const float* density,
                                      const float* pressure, const float* near_pressure,
                                      PosValue* pv, uint32_t n, bool near) {
  const uint32_t j = blockIdx.x * blockDim.x + threadIdx.x;
  if (j >= n) return;
  pv[j].pos = pos[j];
  pv[j].value = make_float4(0.5f / density[j], 0.5f * pressure[j] / density[j],
                            near ? 0.5f * near_pressure[j] / density[j] : 0.0f, 0.0f);
}

template <bool kNear>
__global__ void PressureForceKernel(DeviceGrid grid, Particles p, const float4* __restrict__ pos,
                                    const float* pressure, const float* near_pressure,
                                    const PosValue* __restrict__ pv, SeedConstants c,
                                    Overflow overflow, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n || overflow.Skip(i)) return;
  const float4 xi = pos[i];
  const float pi = pressure[i];
  const float pni = kNear ? near_pressure[i] : 0.0f;
  float fx[kLanes] = {}, fy[kLanes] = {}, fz[kLanes] = {};
  int coincident = 0;  // candidates at distance 0, i itself included
  grid.ForEachNeighborRun(
      grid.SortedCell(i), [&](uint32_t begin, uint32_t end, float sx, float sy, float sz) {
        const float qx = xi.x + sx, qy = xi.y + sy, qz = xi.z + sz;
        for (uint32_t j = begin; j < end; j += kLanes) {
#pragma unroll
          for (int l = 0; l < kLanes; ++l) {
            if (j + l >= end) break;
            const uint32_t k = j + l;
            float dx, dy, dz;
            const float r2 = SquaredDistance(__ldg(pos + k), qx, qy, qz, dx, dy, dz);
            if (r2 == 0) ++coincident;
            if (!(r2 < c.h2 && r2 > 0)) continue;
            const float s = PressureScale<kNear>(c, r2, pi, pni, __ldg(&pv[k].value));
            fx[l] -= dx * s;
            fy[l] -= dy * s;
            fz[l] -= dz * s;
          }
        }
      });
  float force[3] = {LaneSum(fx), LaneSum(fy), LaneSum(fz)};
  if (coincident > 1) AddCoincidentForces<kNear>(grid, pos, p.id, pv, c, i, xi, pi, pni, force);
  ApplyPressureForce(p, pv, c, i, force);
}

// Reads the velocities from the copy made before the pass (pv's values: vx, vy, vz), as the CPU
// does.
__global__ void ViscosityKernel(DeviceGrid grid, Particles p, const float4* __restrict__ pos,
                                const PosValue* __restrict__ pv, SeedConstants c, Overflow overflow,
                                uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n || overflow.Skip(i)) return;
  const float4 xi = pos[i];
  const float4 vi = pv[i].value;
  float ax[kLanes] = {}, ay[kLanes] = {}, az[kLanes] = {}, wsum[kLanes] = {};
  grid.ForEachNeighborRun(
      grid.SortedCell(i), [&](uint32_t begin, uint32_t end, float sx, float sy, float sz) {
        const float qx = xi.x + sx, qy = xi.y + sy, qz = xi.z + sz;
        for (uint32_t j = begin; j < end; j += kLanes) {
#pragma unroll
          for (int l = 0; l < kLanes; ++l) {
            if (j + l >= end) break;
            const uint32_t k = j + l;
            float dx, dy, dz;
            const float r2 = SquaredDistance(__ldg(pos + k), qx, qy, qz, dx, dy, dz);
            if (!(r2 < c.h2)) continue;
            const float w = c.h2 - r2;
            const float w3 = w * w * w;
            const float4 vj = __ldg(&pv[k].value);
            ax[l] += (vj.x - vi.x) * w3;
            ay[l] += (vj.y - vi.y) * w3;
            az[l] += (vj.z - vi.z) * w3;
            wsum[l] += w3;
          }
        }
      });
  ApplyViscosity(p, c, i, LaneSum(ax), LaneSum(ay), LaneSum(az), LaneSum(wsum));
}

// The sort's gather of the predicted positions, which also packs them as float4 for the
// neighbour kernels (one load per candidate instead of three).
__global__ void GatherPredictedKernel(const uint32_t* order, const float* px, const float* py,
                                      const float* pz, float* px2, float* py2, float* pz2,
                                      float4* pos, uint32_t n) {
  const uint32_t k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k >= n) return;
  const uint32_t from = order[k];
  const float x = px[from], y = py[from], z = pz[from];
  px2[k] = x, py2[k] = y, pz2[k] = z;
  pos[k] = make_float4(x, y, z, 0.0f);
}

// The viscosity pass's copy of the velocities, packed as float4 beside the positions.
__global__ void PackVelocityKernel(Particles p, const float4* pos, PosValue* pv, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  pv[i].pos = pos[i];
  pv[i].value = make_float4(p.vx[i], p.vy[i], p.vz[i], 0.0f);
}

// CollideWithDomainWalls (solvers/domain_walls.h) for one axis.
__device__ void CollideWithWall(float lo, float hi, bool periodic, float damping, float& x,
                                float& v) {
  if (periodic) {
    const float length = hi - lo;
    if (x >= hi) x -= length;
    if (x < lo) x += length;
    if (!(x < hi)) x = lo;
    return;
  }
  if (x <= lo) {
    x = lo;
    if (v < 0) v = -v * damping;
  } else if (x >= hi) {
    x = hi;
    if (v > 0) v = -v * damping;
  }
}

__global__ void IntegrateKernel(Particles p, SeedConstants c, GridLayout layout,
                                unsigned long long* limited, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  float v[3] = {p.vx[i], p.vy[i], p.vz[i]};
  const float speed2 = v[0] * v[0] + (v[1] * v[1] + v[2] * v[2]);
  if (speed2 > c.speed_limit * c.speed_limit) {
    const float f = c.speed_limit / sqrtf(speed2);
    v[0] *= f, v[1] *= f, v[2] *= f;
    atomicAdd(limited, 1ull);  // an integer count: the same whatever the order
  }
  float x[3] = {p.x[i] + v[0] * c.dt, p.y[i] + v[1] * c.dt, p.z[i] + v[2] * c.dt};
  for (int a = 0; a < 3; ++a) {
    CollideWithWall(c.domain_lo[a], c.domain_hi[a], layout.periodic[a], c.damping, x[a], v[a]);
  }
  p.x[i] = x[0], p.y[i] = x[1], p.z[i] = x[2];
  p.vx[i] = v[0], p.vy[i] = v[1], p.vz[i] = v[2];
}

__global__ void ObstaclesKernel(Particles p, Obstacles o, float damping, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  float x[3] = {p.x[i], p.y[i], p.z[i]};
  float v[3] = {p.vx[i], p.vy[i], p.vz[i]};
  for (int s = 0; s < o.sphere_count; ++s) {
    const SphereObstacle& sphere = o.spheres[s];
    const float r = sphere.radius;
    const float d[3] = {x[0] - sphere.center[0], x[1] - sphere.center[1], x[2] - sphere.center[2]};
    const float dist2 = d[0] * d[0] + (d[1] * d[1] + d[2] * d[2]);
    if (dist2 >= r * r) continue;
    const float dist = sqrtf(dist2);
    float nrm[3] = {0, 1, 0};
    if (dist > 0) nrm[0] = d[0] / dist, nrm[1] = d[1] / dist, nrm[2] = d[2] / dist;
    for (int a = 0; a < 3; ++a) x[a] = sphere.center[a] + nrm[a] * r;
    // The velocity relative to the obstacle is reflected (exactly v for a static one).
    const float* u = sphere.velocity;
    const float vn = (v[0] - u[0]) * nrm[0] + ((v[1] - u[1]) * nrm[1] + (v[2] - u[2]) * nrm[2]);
    if (vn < 0) {
      const float k = (1 + damping) * vn;
      for (int a = 0; a < 3; ++a) v[a] -= k * nrm[a];
    }
  }
  for (int b = 0; b < o.box_count; ++b) {
    const BoxObstacle& box = o.boxes[b];
    bool inside = true;
    for (int a = 0; a < 3; ++a) inside = inside && x[a] > box.lo[a] && x[a] < box.hi[a];
    if (!inside) continue;
    int axis = 0;
    float best = x[0] - box.lo[0];
    float face = box.lo[0];
    float outward = -1;
    for (int a = 0; a < 3; ++a) {
      if (x[a] - box.lo[a] < best)
        best = x[a] - box.lo[a], axis = a, face = box.lo[a], outward = -1;
      if (box.hi[a] - x[a] < best) best = box.hi[a] - x[a], axis = a, face = box.hi[a], outward = 1;
    }
    x[axis] = face;
    const float u = box.velocity[axis];
    const float vn = v[axis] - u;
    // At rest the bounce is exactly -v damping, a zero's sign included (CollideWithBox).
    if (vn * outward < 0) v[axis] = u == 0 ? -vn * damping : u - vn * damping;
  }
  p.x[i] = x[0], p.y[i] = x[1], p.z[i] = x[2];
  p.vx[i] = v[0], p.vy[i] = v[1], p.vz[i] = v[2];
}

}  // namespace
}  // namespace dysa::cuda
