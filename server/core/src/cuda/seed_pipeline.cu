// The seed solver's passes as CUDA kernels (seed_pipeline.h says why they match the CPU bit
// for bit). Each kernel is the CPU pass of solvers/seed/seed_solver.cc with the same name; the
// comments here say only where the GPU differs in how, never in what, it computes.
#include <cuda_runtime.h>

#include <algorithm>
#include <cstdlib>
#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_scan.cuh>
#include <stdexcept>
#include <string>
#include <utility>

#include "cuda/device_buffer.cuh"
#include "cuda/device_grid.cuh"
#include "cuda/seed_pipeline.h"

namespace dysa::cuda {
namespace {

constexpr int kLanes = 8;  // the CPU's vector width (simd.h), kept as 8 register partial sums

struct Particles {
  float *x, *y, *z;     // position, m
  float *vx, *vy, *vz;  // velocity, m/s
  float *px, *py, *pz;  // predicted position, m (after the sort: the grid's points)
  uint32_t* id;
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

// The neighbour list (runs without periodic axes): the density pass scans the 27 cells once and
// keeps, per particle, the candidates within h (those at distance 0 included); the pressure and
// viscosity passes, which would scan the same candidates around the same predicted positions
// (about 5 per neighbour), read the list instead.
//
// The list is lane-major: lane 0's neighbours in candidate order, then lane 1's, and so on, so a
// thread adds each lane's terms into one register and the lane into the total when the next lane
// starts. That is LaneSum's order (lanes without neighbours would add +0 to a sum that is never
// -0: skipping them changes nothing, as in seed_pipeline.h), with no indexing into the 8 partial
// sums. An entry is
// 16 bits, the run (0..8, of NeighbourRuns) and the offset in it, whose low 3 bits are the lane;
// a thread keeps its runs' starts in shared memory to turn it back into a particle index.
// Entries go 8 to a 16-byte chunk, chunk c of particle i at c * stride + i: a thread writes a
// chunk with one store, and a warp reads its chunk c in one coalesced load.
//
// A particle with more neighbours than the capacity, or a run too long for an entry, is left to
// the grid kernels (Overflow); the step reports the largest count, and the host grows the list.
constexpr int kRuns = 9;
constexpr uint32_t kOffsetBits = 12;
constexpr uint32_t kMaxRunLength = 1u << kOffsetBits;
constexpr uint32_t kEntriesPerChunk = 8;
constexpr uint32_t kUnlisted = 0xFFFFFFFFu;  // the count of a particle with a run too long

struct NeighbourList {
  uint4* chunk;     // chunk c of particle i at c * stride + i
  uint32_t* count;  // neighbours of each particle; above capacity: the grid kernels compute it
  uint64_t stride;
  uint32_t capacity;  // entries per particle, a multiple of kEntriesPerChunk
};

// The particles the grid kernels compute: all of them without a list (count null), otherwise
// those the list kernels left (more neighbours than the capacity).
struct Overflow {
  const uint32_t* count;
  uint32_t capacity;
  __device__ bool Skip(uint32_t i) const { return count != nullptr && count[i] <= capacity; }
};

struct Densities {
  float *density, *near_density, *pressure, *near_pressure;
};

// The runs of DeviceGrid::ForEachNeighborRun without periodic axes, in its order: run
// 3 (dz + 1) + (dy + 1) is the row (y + dy, z + dz), empty where that row lies outside the grid.
__device__ void NeighbourRuns(const DeviceGrid& grid, int3 cell, uint32_t begin[kRuns],
                              uint32_t end[kRuns]) {
  const int nx = grid.layout.dims[0], ny = grid.layout.dims[1], nz = grid.layout.dims[2];
  const int x0 = cell.x > 0 ? cell.x - 1 : 0;
  const int x1 = cell.x + 1 < nx ? cell.x + 1 : nx - 1;
#pragma unroll
  for (int r = 0; r < kRuns; ++r) {
    const int z = cell.z + r / 3 - 1, y = cell.y + r % 3 - 1;
    begin[r] = end[r] = 0;
    if (z >= 0 && z < nz && y >= 0 && y < ny) {
      const uint32_t row = uint32_t(nx) * (y + uint32_t(ny) * z);
      begin[r] = grid.cell_start[row + x0];
      end[r] = grid.cell_start[row + x1 + 1];
    }
  }
}

// Shifts an entry into the top of a chunk; after 8, the first is in the low half of c.x.
__device__ void ShiftIn(uint4& c, uint32_t entry) {
  c.x = __funnelshift_r(c.x, c.y, 16);
  c.y = __funnelshift_r(c.y, c.z, 16);
  c.z = __funnelshift_r(c.z, c.w, 16);
  c.w = __funnelshift_r(c.w, entry, 16);
}

// Calls next_lane() where a lane's neighbours end and another's begin, and visit(j) for each of
// particle i's `count` neighbours in list order; run_begin holds the thread's run starts.
// kWritten: the list was written by this kernel (plain loads, not the read-only cache's).
template <bool kWritten, class NextLane, class Visit>
__device__ void ForEachListed(const NeighbourList& list, uint32_t i, uint32_t count,
                              const uint32_t (*run_begin)[kBlock], NextLane&& next_lane,
                              Visit&& visit) {
  const uint4* in = list.chunk + i;
  uint32_t lane = 0;
  for (uint32_t base = 0; base < count; base += kEntriesPerChunk) {
    const uint4* at = in + uint64_t(base / kEntriesPerChunk) * list.stride;
    const uint4 c = kWritten ? *at : __ldg(at);
#pragma unroll
    for (uint32_t s = 0; s < kEntriesPerChunk; ++s) {
      if (base + s >= count) break;
      const uint32_t word = s < 2 ? c.x : s < 4 ? c.y : s < 6 ? c.z : c.w;
      const uint32_t e = (word >> (16 * (s & 1))) & 0xFFFF;
      const uint32_t offset = e & (kMaxRunLength - 1);
      if ((offset & (kLanes - 1)) != lane) {
        next_lane();
        lane = offset & (kLanes - 1);
      }
      visit(run_begin[e >> kOffsetBits][threadIdx.x] + offset);
    }
  }
}

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
template <bool kNear>
__device__ void AddCoincidentForces(const DeviceGrid& grid, const float4* pos, const uint32_t* id,
                                    const float4* factor, const SeedConstants& c, uint32_t i,
                                    float4 xi, float pi, float pni, float force[3]) {
  grid.ForEachNeighborRun(grid.SortedCell(i), [&](uint32_t begin, uint32_t end, float sx, float sy,
                                                  float sz) {
    for (uint32_t j = begin; j < end; ++j) {
      const float4 pj = pos[j];
      if (j == i || pj.x - (xi.x + sx) != 0 || pj.y - (xi.y + sy) != 0 || pj.z - (xi.z + sz) != 0) {
        continue;
      }
      const float4 f = factor[j];
      float magnitude = c.spiky2_grad * c.h * (pi * f.x + f.y);
      if (kNear) magnitude += c.spiky3_grad * c.h * c.h * (pni * f.x + f.z);
      float d[3];
      CoincidentDirection(id[i], id[j], d);
      for (int a = 0; a < 3; ++a) force[a] -= d[a] * magnitude;
    }
  });
}

__device__ void ApplyPressureForce(Particles p, const float4* factor, const SeedConstants& c,
                                   uint32_t i, const float force[3]) {
  const float scale = c.mass_dt * 2 * factor[i].x;
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

template <bool kNear>
__global__ void DensityKernel(DeviceGrid grid, const float4* __restrict__ pos, Densities d,
                              SeedConstants c, Overflow overflow, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n || overflow.Skip(i)) return;
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
// particle for one load: 0.5 / rho, 0.5 p / rho, 0.5 pn / rho.
__global__ void PressureFactorsKernel(const float* density, const float* pressure,
                                      const float* near_pressure, float4* factor, uint32_t n,
                                      bool near) {
  const uint32_t j = blockIdx.x * blockDim.x + threadIdx.x;
  if (j >= n) return;
  factor[j] = make_float4(0.5f / density[j], 0.5f * pressure[j] / density[j],
                          near ? 0.5f * near_pressure[j] / density[j] : 0.0f, 0.0f);
}

template <bool kNear>
__global__ void PressureForceKernel(DeviceGrid grid, Particles p, const float4* __restrict__ pos,
                                    const float* pressure, const float* near_pressure,
                                    const float4* __restrict__ factor, SeedConstants c,
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
            const float s = PressureScale<kNear>(c, r2, pi, pni, __ldg(factor + k));
            fx[l] -= dx * s;
            fy[l] -= dy * s;
            fz[l] -= dz * s;
          }
        }
      });
  float force[3] = {LaneSum(fx), LaneSum(fy), LaneSum(fz)};
  if (coincident > 1) {
    AddCoincidentForces<kNear>(grid, pos, p.id, factor, c, i, xi, pi, pni, force);
  }
  ApplyPressureForce(p, factor, c, i, force);
}

// Reads the velocities from the copy made before the pass (vel: vx, vy, vz), as the CPU does.
__global__ void ViscosityKernel(DeviceGrid grid, Particles p, const float4* __restrict__ pos,
                                const float4* __restrict__ vel, SeedConstants c, Overflow overflow,
                                uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n || overflow.Skip(i)) return;
  const float4 xi = pos[i];
  const float4 vi = vel[i];
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
            const float4 vj = __ldg(vel + k);
            ax[l] += (vj.x - vi.x) * w3;
            ay[l] += (vj.y - vi.y) * w3;
            az[l] += (vj.z - vi.z) * w3;
            wsum[l] += w3;
          }
        }
      });
  ApplyViscosity(p, c, i, LaneSum(ax), LaneSum(ay), LaneSum(az), LaneSum(wsum));
}

// The list kernels, launched with kBlock threads (the shared run starts). Each measures from
// ForEachNeighborRun's query point: the position plus a zero shift (which turns -0 into +0).

// Builds particle i's list, then computes its density from it: the scan only tests the
// candidates, and the square roots wait for a loop over the neighbours. In the scan about 1
// candidate in 5 is a neighbour, and a warp would run the square root of every candidate some
// thread keeps.
template <bool kNear>
__global__ void DensityListKernel(DeviceGrid grid, const float4* __restrict__ pos,
                                  NeighbourList list, Densities d, SeedConstants c,
                                  unsigned long long* most_neighbours, uint32_t n) {
  __shared__ uint32_t run_begin[kRuns][kBlock];
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const float4 xi = pos[i];
  const float qx = xi.x + 0.0f, qy = xi.y + 0.0f, qz = xi.z + 0.0f;
  uint32_t begin[kRuns], end[kRuns];
  NeighbourRuns(grid, grid.SortedCell(i), begin, end);
  bool listable = true;
#pragma unroll
  for (int r = 0; r < kRuns; ++r) listable = listable && end[r] - begin[r] <= kMaxRunLength;
  if (!listable) {
    list.count[i] = kUnlisted;
    return;
  }
  uint32_t count = 0;  // counts on past the capacity: the host grows the list to the largest
  uint4 chunk = make_uint4(0, 0, 0, 0);
  uint4* out = list.chunk + i;
#pragma unroll 1
  for (uint32_t l = 0; l < kLanes; ++l) {
#pragma unroll
    for (int r = 0; r < kRuns; ++r) {
      for (uint32_t j = begin[r] + l; j < end[r]; j += kLanes) {
        float dx, dy, dz;
        if (!(SquaredDistance(__ldg(pos + j), qx, qy, qz, dx, dy, dz) < c.h2)) continue;
        if (++count > list.capacity) continue;
        ShiftIn(chunk, uint32_t(r) << kOffsetBits | (j - begin[r]));
        if (count % kEntriesPerChunk == 0) {
          out[uint64_t(count / kEntriesPerChunk - 1) * list.stride] = chunk;
        }
      }
    }
  }
  list.count[i] = count;
  if (count > list.capacity) {
    atomicMax(most_neighbours, count);  // rare: one atomic per overflowing particle
    return;
  }
  if (count % kEntriesPerChunk != 0) {
    for (uint32_t s = count % kEntriesPerChunk; s < kEntriesPerChunk; ++s) ShiftIn(chunk, 0);
    out[uint64_t(count / kEntriesPerChunk) * list.stride] = chunk;
  }
#pragma unroll
  for (int r = 0; r < kRuns; ++r) run_begin[r][threadIdx.x] = begin[r];
  float sum2 = 0, sum3 = 0;    // LaneSum's running totals
  float lane2 = 0, lane3 = 0;  // the current lane's
  ForEachListed<true>(
      list, i, count, run_begin,
      [&] {
        sum2 += lane2, sum3 += lane3;
        lane2 = 0, lane3 = 0;
      },
      [&](uint32_t j) {
        float dx, dy, dz;
        const float q = c.h - sqrtf(SquaredDistance(__ldg(pos + j), qx, qy, qz, dx, dy, dz));
        lane2 += q * q;
        if (kNear) lane3 += q * q * q;
      });
  sum2 += lane2, sum3 += lane3;
  StoreDensity<kNear>(d, c, i, sum2, sum3);
}

// Particle i's neighbour count; when the list holds them, also writes its run starts to
// run_begin.
__device__ uint32_t ListedCount(const DeviceGrid& grid, const NeighbourList& list, uint32_t i,
                                uint32_t (*run_begin)[kBlock]) {
  const uint32_t count = list.count[i];
  if (count > list.capacity) return count;
  uint32_t begin[kRuns], end[kRuns];
  NeighbourRuns(grid, grid.SortedCell(i), begin, end);
#pragma unroll
  for (int r = 0; r < kRuns; ++r) run_begin[r][threadIdx.x] = begin[r];
  return count;
}

template <bool kNear>
__global__ void PressureForceListKernel(DeviceGrid grid, Particles p,
                                        const float4* __restrict__ pos, const float* pressure,
                                        const float* near_pressure,
                                        const float4* __restrict__ factor, NeighbourList list,
                                        SeedConstants c, uint32_t n) {
  __shared__ uint32_t run_begin[kRuns][kBlock];
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const uint32_t count = ListedCount(grid, list, i, run_begin);
  if (count > list.capacity) return;
  const float4 xi = pos[i];
  const float qx = xi.x + 0.0f, qy = xi.y + 0.0f, qz = xi.z + 0.0f;
  const float pi = pressure[i];
  const float pni = kNear ? near_pressure[i] : 0.0f;
  float force[3] = {0, 0, 0};  // LaneSum's running totals
  float fx = 0, fy = 0, fz = 0;
  int coincident = 0;  // neighbours at distance 0, i itself included
  ForEachListed<false>(
      list, i, count, run_begin,
      [&] {
        force[0] += fx, force[1] += fy, force[2] += fz;
        fx = 0, fy = 0, fz = 0;
      },
      [&](uint32_t j) {
        float dx, dy, dz;
        const float r2 = SquaredDistance(__ldg(pos + j), qx, qy, qz, dx, dy, dz);
        if (r2 == 0) {
          ++coincident;
          return;
        }
        const float s = PressureScale<kNear>(c, r2, pi, pni, __ldg(factor + j));
        fx -= dx * s;
        fy -= dy * s;
        fz -= dz * s;
      });
  force[0] += fx, force[1] += fy, force[2] += fz;
  if (coincident > 1) {
    AddCoincidentForces<kNear>(grid, pos, p.id, factor, c, i, xi, pi, pni, force);
  }
  ApplyPressureForce(p, factor, c, i, force);
}

__global__ void ViscosityListKernel(DeviceGrid grid, Particles p, const float4* __restrict__ pos,
                                    const float4* __restrict__ vel, NeighbourList list,
                                    SeedConstants c, uint32_t n) {
  __shared__ uint32_t run_begin[kRuns][kBlock];
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const uint32_t count = ListedCount(grid, list, i, run_begin);
  if (count > list.capacity) return;
  const float4 xi = pos[i];
  const float qx = xi.x + 0.0f, qy = xi.y + 0.0f, qz = xi.z + 0.0f;
  const float4 vi = vel[i];
  float sum_x = 0, sum_y = 0, sum_z = 0, sum_w = 0;  // LaneSum's running totals
  float ax = 0, ay = 0, az = 0, wsum = 0;
  ForEachListed<false>(
      list, i, count, run_begin,
      [&] {
        sum_x += ax, sum_y += ay, sum_z += az, sum_w += wsum;
        ax = 0, ay = 0, az = 0, wsum = 0;
      },
      [&](uint32_t j) {
        float dx, dy, dz;
        const float w = c.h2 - SquaredDistance(__ldg(pos + j), qx, qy, qz, dx, dy, dz);
        const float w3 = w * w * w;
        const float4 vj = __ldg(vel + j);
        ax += (vj.x - vi.x) * w3;
        ay += (vj.y - vi.y) * w3;
        az += (vj.z - vi.z) * w3;
        wsum += w3;
      });
  sum_x += ax, sum_y += ay, sum_z += az, sum_w += wsum;
  ApplyViscosity(p, c, i, sum_x, sum_y, sum_z, sum_w);
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

// The viscosity pass's copy of the velocities, packed as float4.
__global__ void PackVelocityKernel(Particles p, float4* vel, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) vel[i] = make_float4(p.vx[i], p.vy[i], p.vz[i], 0.0f);
}

// CollideWithDomainWalls (common_passes.h) for one axis.
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
    const float vn = v[0] * nrm[0] + (v[1] * nrm[1] + v[2] * nrm[2]);
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
    if (v[axis] * outward < 0) v[axis] = -v[axis] * damping;
  }
  p.x[i] = x[0], p.y[i] = x[1], p.z[i] = x[2];
  p.vx[i] = v[0], p.vy[i] = v[1], p.vz[i] = v[2];
}

}  // namespace

struct SeedPipeline::Impl {
  explicit Impl(int device_index) : device(device_index), stream(device_index) {
    // DYSA_CUDA_SEED_LIST=K fixes the neighbour list's capacity at K entries per particle (0:
    // no list, the grid kernels only), for tests of the grid kernels and the overflow path.
    if (const char* value = std::getenv("DYSA_CUDA_SEED_LIST")) {
      const unsigned long k = std::strtoul(value, nullptr, 10);
      list_want = uint32_t(RoundUp(std::min<unsigned long>(k, kMaxListCapacity), kEntriesPerChunk));
      list_fixed = true;
    }
  }

  // The neighbour list's capacity, entries per particle: the first, enough for the thesis
  // fluid's ~97 neighbours (and a 100M-particle list in 26 GB); the most it grows to.
  static constexpr uint32_t kListCapacity = 128;
  static constexpr uint32_t kMaxListCapacity = 1024;

  static uint64_t RoundUp(uint64_t x, uint64_t to) { return (x + to - 1) / to * to; }

  int device;
  Stream stream;
  SeedStepConfig config;
  std::vector<std::string> passes;
  uint32_t n = 0;
  // Particle arrays and their permutation targets (swapped after each sort).
  DeviceBuffer<float> x, y, z, vx, vy, vz, px, py, pz;
  DeviceBuffer<float> x2, y2, z2, vx2, vy2, vz2, px2, py2, pz2;
  DeviceBuffer<uint32_t> id, id2;
  mutable DeviceBuffer<float> frame_staging;  // DownloadById's
  DeviceBuffer<float> density, near_density, pressure, near_pressure;
  DeviceBuffer<float4> pos4;      // the grid's points (px, py, pz), for the neighbour kernels
  DeviceBuffer<float4> scratch4;  // the pressure factors; the velocity copy
  DeviceBuffer<uint4> list_chunks;
  DeviceBuffer<uint32_t> list_count;
  uint32_t list_want = kListCapacity;  // the capacity the next step asks for
  bool list_fixed = false;             // DYSA_CUDA_SEED_LIST: no growth
  bool list_refused = false;           // no room for list_want; not asked again until Upload
  GridSorter sorter;
  DeviceBuffer<SphereObstacle> spheres;
  DeviceBuffer<BoxObstacle> boxes;
  // Copied back per step: [0] limited, [1] non-finite, [2] the most neighbours of a particle
  // the list could not hold.
  PinnedBuffer<unsigned long long> flags;
  DeviceBuffer<unsigned long long> device_flags;
  EventTimer timer;

  Particles View() {
    return {x.data(),  y.data(),  z.data(),  vx.data(), vy.data(),
            vz.data(), px.data(), py.data(), pz.data(), id.data()};
  }

  void Allocate(uint32_t count) {
    for (DeviceBuffer<float>* b :
         {&x,   &y,   &z,       &vx,           &vy,       &vz,           &px,  &py,
          &pz,  &x2,  &y2,      &z2,           &vx2,      &vy2,          &vz2, &px2,
          &py2, &pz2, &density, &near_density, &pressure, &near_pressure}) {
      b->Resize(count);
    }
    id.Resize(count);
    id2.Resize(count);
    pos4.Resize(count);
    scratch4.Resize(count);
    list_count.Resize(count);
    sorter.Reserve(count);
    n = count;
  }

  void Sort() {
    const Particles p = View();
    sorter.Sort(config.grid, p.px, p.py, p.pz, n, stream.get());
    const uint32_t* order = sorter.order();
    Gather(order, x, x2), Gather(order, y, y2), Gather(order, z, z2);
    Gather(order, vx, vx2), Gather(order, vy, vy2), Gather(order, vz, vz2);
    if (n > 0) {
      GatherPredictedKernel<<<(n + kBlock - 1) / kBlock, kBlock, 0, stream.get()>>>(
          order, px.data(), py.data(), pz.data(), px2.data(), py2.data(), pz2.data(), pos4.data(),
          n);
    }
    px.swap(px2), py.swap(py2), pz.swap(pz2);
    Gather(order, id, id2);
  }

  template <class T>
  void Gather(const uint32_t* order, DeviceBuffer<T>& data, DeviceBuffer<T>& target) {
    GatherByOrder(order, data.data(), target.data(), n, stream.get());
    data.swap(target);
  }

  // Chunk c of a particle's list lies c * ListStride() chunks after chunk 0; rounded up so that
  // a warp's chunks start on a 128-byte line.
  uint64_t ListStride() const { return RoundUp(n, 8); }

  // The list's capacity for this step, 0 for the grid kernels: periodic axes (the list does not
  // carry the runs' shifts), or no room. The list takes at most half the GPU memory free besides
  // it, so that a 100M-particle run on a 141 GB GPU keeps it and a larger one does without.
  uint32_t PrepareList() {
    const GridLayout& g = config.grid;
    if (n == 0 || list_want == 0 || g.periodic[0] || g.periodic[1] || g.periodic[2] ||
        !(config.constants.h2 > 0)) {
      return 0;
    }
    const uint64_t stride = ListStride();
    const uint64_t chunks = stride * (list_want / kEntriesPerChunk);
    if (list_chunks.capacity() < chunks && !list_refused) {
      size_t free = 0, total = 0;
      CheckCuda(cudaMemGetInfo(&free, &total), "reading the free GPU memory");
      const uint64_t own = list_chunks.capacity() * sizeof(uint4);
      if (chunks * sizeof(uint4) <= (free + own) / 2) {
        try {
          list_chunks.Resize(chunks);
        } catch (const std::runtime_error&) {
          cudaGetLastError();  // clears the failed allocation's error: the grid kernels go on
        }
      }
      list_refused = list_chunks.capacity() < chunks;
    }
    // Without room for list_want, the capacity the list has (if any near it).
    const uint32_t k =
        uint32_t(std::min<uint64_t>(list_want, list_chunks.capacity() / stride * kEntriesPerChunk));
    return k >= std::min(list_want, kListCapacity) ? k : 0;
  }

  // After a step in which some particle had more neighbours than the list holds: a quarter more
  // than that for the next steps.
  void GrowList(uint32_t capacity, uint64_t most) {
    if (capacity == 0 || most <= capacity || list_fixed || list_refused) return;
    list_want = uint32_t(std::min<uint64_t>(RoundUp(most + most / 4, 32), kMaxListCapacity));
  }
};

SeedPipeline::SeedPipeline(int device) : impl_(std::make_unique<Impl>(device)) {}
SeedPipeline::~SeedPipeline() = default;

size_t SeedPipeline::size() const { return impl_->n; }

std::vector<std::string> SeedPipeline::Configure(const SeedStepConfig& config) {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  m.config = config;
  m.spheres.Assign(config.spheres, m.stream.get());
  m.boxes.Assign(config.boxes, m.stream.get());
  m.passes = {"external_forces", "neighbour_grid", "density", "pressure_force"};
  if (config.viscosity) m.passes.push_back("viscosity");
  m.passes.push_back("integrate");
  if (!config.spheres.empty() || !config.boxes.empty()) m.passes.push_back("obstacles");
  m.timer.Resize(m.passes.size() + 1);
  m.sorter.Configure(config.grid);
  m.flags.Resize(3);
  m.device_flags.Resize(3);
  CheckCuda(cudaStreamSynchronize(m.stream.get()), "configuring the seed step");
  return m.passes;
}

void SeedPipeline::Upload(size_t n, const uint32_t* id, const float* position,
                          const float* velocity) {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  if (n > uint64_t(UINT32_MAX) / 2) throw std::length_error("too many particles for the GPU");
  m.Allocate(uint32_t(n));
  m.list_refused = false;
  UploadInterleaved(position, n, m.x, m.y, m.z, m.stream.get());
  UploadInterleaved(velocity, n, m.vx, m.vy, m.vz, m.stream.get());
  CheckCuda(cudaMemcpyAsync(m.id.data(), id, n * sizeof(uint32_t), cudaMemcpyHostToDevice,
                            m.stream.get()),
            "uploading ids");
  // Density and pressure are computed by the step; zero them so a download before the first
  // step reads zeros, as the CPU's freshly spawned arrays.
  for (DeviceBuffer<float>* b :
       {&m.px, &m.py, &m.pz, &m.density, &m.near_density, &m.pressure, &m.near_pressure}) {
    b->Zero(m.stream.get());
  }
  CheckCuda(cudaStreamSynchronize(m.stream.get()), "uploading particles");
}

void SeedPipeline::Download(uint32_t* id, float* position, float* velocity, float* predicted,
                            float* density, float* near_density, float* pressure,
                            float* near_pressure) const {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  const size_t n = m.n;
  if (id) m.id.CopyTo(id, n, m.stream.get());
  if (position) DownloadInterleaved(m.x, m.y, m.z, n, position, m.stream.get());
  if (velocity) DownloadInterleaved(m.vx, m.vy, m.vz, n, velocity, m.stream.get());
  if (predicted) DownloadInterleaved(m.px, m.py, m.pz, n, predicted, m.stream.get());
  if (density) m.density.CopyTo(density, n, m.stream.get());
  if (near_density) m.near_density.CopyTo(near_density, n, m.stream.get());
  if (pressure) m.pressure.CopyTo(pressure, n, m.stream.get());
  if (near_pressure) m.near_pressure.CopyTo(near_pressure, n, m.stream.get());
  CheckCuda(cudaStreamSynchronize(m.stream.get()), "downloading particles");
}

StepOutcome SeedPipeline::Step() {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  const SeedStepConfig& cfg = m.config;
  const SeedConstants c = cfg.constants;
  const uint32_t n = m.n;
  cudaStream_t s = m.stream.get();
  const unsigned blocks = unsigned((n + kBlock - 1) / kBlock);
  const bool launch = n > 0;
  size_t pass = 0;
  CheckCuda(cudaMemsetAsync(m.device_flags.data(), 0, 3 * sizeof(unsigned long long), s),
            "clearing the step's flags");
  auto begin_pass = [&] { m.timer.Record(pass++, s); };
  const uint32_t capacity = launch ? m.PrepareList() : 0;
  const NeighbourList list{m.list_chunks.data(), m.list_count.data(), m.ListStride(), capacity};
  // With a list, the grid kernels compute only the particles it could not hold.
  const Overflow overflow{capacity > 0 ? m.list_count.data() : nullptr, capacity};
  const Densities densities{m.density.data(), m.near_density.data(), m.pressure.data(),
                            m.near_pressure.data()};
  const float4* pos = m.pos4.data();
  float4* scratch = m.scratch4.data();

  begin_pass();  // external_forces
  if (launch) {
    ExternalForcesKernel<<<blocks, kBlock, 0, s>>>(m.View(), n, cfg.gravity_dv, cfg.lookahead);
  }
  begin_pass();  // neighbour_grid
  m.Sort();
  const DeviceGrid grid = m.sorter.View();
  begin_pass();  // density
  if (launch) {
    unsigned long long* most = m.device_flags.data() + 2;
    if (cfg.near) {
      if (capacity > 0) {
        DensityListKernel<true><<<blocks, kBlock, 0, s>>>(grid, pos, list, densities, c, most, n);
      }
      DensityKernel<true><<<blocks, kBlock, 0, s>>>(grid, pos, densities, c, overflow, n);
    } else {
      if (capacity > 0) {
        DensityListKernel<false><<<blocks, kBlock, 0, s>>>(grid, pos, list, densities, c, most, n);
      }
      DensityKernel<false><<<blocks, kBlock, 0, s>>>(grid, pos, densities, c, overflow, n);
    }
  }
  begin_pass();  // pressure_force
  if (launch) {
    PressureFactorsKernel<<<blocks, kBlock, 0, s>>>(m.density.data(), m.pressure.data(),
                                                    m.near_pressure.data(), scratch, n, cfg.near);
    const Particles p = m.View();
    const float* pr = m.pressure.data();
    const float* near_pr = m.near_pressure.data();
    if (cfg.near) {
      if (capacity > 0) {
        PressureForceListKernel<true>
            <<<blocks, kBlock, 0, s>>>(grid, p, pos, pr, near_pr, scratch, list, c, n);
      }
      PressureForceKernel<true>
          <<<blocks, kBlock, 0, s>>>(grid, p, pos, pr, near_pr, scratch, c, overflow, n);
    } else {
      if (capacity > 0) {
        PressureForceListKernel<false>
            <<<blocks, kBlock, 0, s>>>(grid, p, pos, pr, near_pr, scratch, list, c, n);
      }
      PressureForceKernel<false>
          <<<blocks, kBlock, 0, s>>>(grid, p, pos, pr, near_pr, scratch, c, overflow, n);
    }
  }
  if (cfg.viscosity) {
    begin_pass();  // viscosity
    if (launch) {
      PackVelocityKernel<<<blocks, kBlock, 0, s>>>(m.View(), scratch, n);
      if (capacity > 0) {
        ViscosityListKernel<<<blocks, kBlock, 0, s>>>(grid, m.View(), pos, scratch, list, c, n);
      }
      ViscosityKernel<<<blocks, kBlock, 0, s>>>(grid, m.View(), pos, scratch, c, overflow, n);
    }
  }
  begin_pass();  // integrate
  if (launch) {
    IntegrateKernel<<<blocks, kBlock, 0, s>>>(m.View(), c, cfg.grid, m.device_flags.data(), n);
  }
  if (!cfg.spheres.empty() || !cfg.boxes.empty()) {
    begin_pass();  // obstacles
    const Obstacles o{m.spheres.data(), int(cfg.spheres.size()), m.boxes.data(),
                      int(cfg.boxes.size())};
    if (launch) ObstaclesKernel<<<blocks, kBlock, 0, s>>>(m.View(), o, c.damping, n);
  }
  m.timer.Record(pass, s);
  const Particles p = m.View();
  CheckFinite(p.x, p.y, p.z, p.vx, p.vy, p.vz, n, m.device_flags.data() + 1, s);
  CheckCuda(cudaGetLastError(), "launching the seed step");
  m.flags.CopyFrom(m.device_flags, 3, s);
  CheckCuda(cudaStreamSynchronize(s), "running the seed step");
  m.GrowList(capacity, m.flags.data()[2]);

  StepOutcome outcome;
  outcome.pass_ms = m.timer.ElapsedMs(pass);
  outcome.limited = m.flags.data()[0];
  outcome.finite = m.flags.data()[1] == 0;
  return outcome;
}

void SeedPipeline::DownloadById(float* position, float* velocity, float* density) const {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  cudaStream_t s = m.stream.get();
  const uint32_t* id = m.id.data();
  if (position) {
    cuda::DownloadById(id, m.x.data(), m.y.data(), m.z.data(), m.n, position, m.frame_staging, s);
  }
  if (velocity) {
    cuda::DownloadById(id, m.vx.data(), m.vy.data(), m.vz.data(), m.n, velocity, m.frame_staging,
                       s);
  }
  if (density) {
    cuda::DownloadById(id, m.density.data(), nullptr, nullptr, m.n, density, m.frame_staging, s);
  }
}

uint64_t SeedPipeline::DeviceBytes() const {
  const Impl& m = *impl_;
  // 22 float arrays (positions, velocities, predictions, their permutation targets, densities,
  // pressures), two id arrays, the packed positions and the scratch (float4), the neighbour
  // counts, the neighbour list, and the grid's keys, order and cell starts.
  return uint64_t(m.x.capacity()) * (22 * sizeof(float) + 2 * sizeof(uint32_t)) +
         uint64_t(m.pos4.capacity() + m.scratch4.capacity()) * sizeof(float4) +
         uint64_t(m.list_count.capacity()) * sizeof(uint32_t) +
         uint64_t(m.list_chunks.capacity()) * sizeof(uint4) + m.sorter.DeviceBytes();
}

}  // namespace dysa::cuda
