// The seed pipeline's kernels over its neighbour list (seed_neighbour_list.cuh): the density
// pass that writes the list and the pressure force and viscosity passes that read it, each the
// grid kernel's arithmetic (seed_kernels.cuh) in the grid kernel's order.
#pragma once

#include <cuda_runtime.h>

#include <cstdint>

#include "cuda/device_buffer.cuh"
#include "cuda/device_grid.cuh"
#include "cuda/seed_kernels.cuh"
#include "cuda/seed_neighbour_list.cuh"

namespace dysa::cuda {
// Each file that includes this gets its own copy of these kernels.
namespace {

// The list kernels, launched with kBlock threads (the readers' run tables in shared memory). Each
// measures from ForEachNeighborRun's query point: the position plus a zero shift (which turns -0
// into +0).

// The grid kernel's density, in the same 8 register lanes and one pass over each run, that also
// records the neighbours (2 bit operations a candidate, the words stored every 32 blocks).
// Unlike the grid kernel it loads a block's 8 candidates at once, before testing any (pos has
// kLanes - 1 entries of padding past the particles; lanes past the run's end are masked), so
// the loads overlap; square roots only for the lanes within h (a masked lane adds +0, which
// changes nothing; a warp skips a block where none of its threads has one). At most 64
// registers: 4 blocks an SM.
// A particle with more blocks than the list holds still gets its density here; only its list
// is dropped (units 0), and `unlisted` counts it.
template <bool kNear>
__global__ void __launch_bounds__(kBlock, 4)
    DensityListKernel(DeviceGrid grid, const float4* __restrict__ pos, NeighbourList list,
                      Densities d, SeedConstants c, unsigned long long* unlisted, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const float4 xi = pos[i];
  const float qx = xi.x + 0.0f, qy = xi.y + 0.0f, qz = xi.z + 0.0f;
  const int3 cell = grid.SortedCell(i);
  float sum2[kLanes] = {}, sum3[kLanes] = {};
  uint32_t lane_bits[kLanes] = {};  // the lanes' current words
  uint32_t units = 0;
  uint32_t t = 0;  // blocks so far
#pragma unroll 1
  for (int r = 0; r < kRuns; ++r) {
    uint32_t begin, end;
    NeighbourRun(grid, cell, r, begin, end);
    for (uint32_t j = begin; j < end; j += kLanes) {
      const uint32_t bit = 1u << (t % kBlocksPerWord);
      float r2[kLanes];
      uint32_t inside = 0;
#pragma unroll
      for (int l = 0; l < kLanes; ++l) {
        float dx, dy, dz;
        r2[l] = SquaredDistance(__ldg(pos + j + l), qx, qy, qz, dx, dy, dz);
        if (j + l < end && r2[l] < c.h2) {
          inside |= 1u << l;
          lane_bits[l] |= bit;
        }
      }
      if (inside != 0) {
#pragma unroll
        for (int l = 0; l < kLanes; ++l) {
          const float q = (inside >> l & 1) ? c.h - sqrtf(r2[l]) : 0.0f;
          sum2[l] += q * q;
          if (kNear) sum3[l] += q * q * q;
        }
      }
      if (++t % kBlocksPerWord == 0)
        StoreListWords(list, i, t / kBlocksPerWord - 1, lane_bits, units);
    }
  }
  if (t % kBlocksPerWord != 0) StoreListWords(list, i, t / kBlocksPerWord, lane_bits, units);
  const bool listed = t <= list.capacity;
  list.units[i] = listed ? units : 0;
  // One atomic per warp with unlisted particles.
  const uint32_t left = __ballot_sync(__activemask(), !listed);
  if (left != 0 && (threadIdx.x % 32) == uint32_t(__ffs(left) - 1)) {
    atomicAdd(unlisted, (unsigned long long)__popc(left));
  }
  StoreDensity<kNear>(d, c, i, LaneSum(sum2), LaneSum(sum3));
}

template <bool kNear>
__global__ void __launch_bounds__(kBlock, 4)
    PressureForceListKernel(DeviceGrid grid, Particles p, const float4* __restrict__ pos,
                            const float* pressure, const float* near_pressure,
                            const PosValue* __restrict__ pv, NeighbourList list, SeedConstants c,
                            uint32_t n) {
  __shared__ uint32_t base[kRuns][kBlock], starts[kMaxListWords][kBlock];
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const uint32_t units = list.units[i];
  if (units == 0) return;  // the grid kernel's
  const uint32_t before = ListedRuns(grid, i, base, starts);
  const float4 xi = pos[i];
  const float qx = xi.x + 0.0f, qy = xi.y + 0.0f, qz = xi.z + 0.0f;
  const float pi = pressure[i];
  const float pni = kNear ? near_pressure[i] : 0.0f;
  float force[3] = {0, 0, 0};  // LaneSum's running totals
  float fx = 0, fy = 0, fz = 0;
  int coincident = 0;  // neighbours at distance 0, i itself included
  ForEachListed(
      ListCursor(list, i, units, base, starts, before),
      [&](uint32_t j) {
        return PosValue{__ldg(&pv[j].pos), __ldg(&pv[j].value)};
      },
      [&] {
        force[0] += fx, force[1] += fy, force[2] += fz;
        fx = 0, fy = 0, fz = 0;
      },
      [&](const PosValue& nb) {
        float dx, dy, dz;
        const float r2 = SquaredDistance(nb.pos, qx, qy, qz, dx, dy, dz);
        if (r2 == 0) {
          ++coincident;
          return;
        }
        const float s = PressureScale<kNear>(c, r2, pi, pni, nb.value);
        fx -= dx * s;
        fy -= dy * s;
        fz -= dz * s;
      });
  force[0] += fx, force[1] += fy, force[2] += fz;
  if (coincident > 1) AddCoincidentForces<kNear>(grid, pos, p.id, pv, c, i, xi, pi, pni, force);
  ApplyPressureForce(p, pv, c, i, force);
}

__global__ void __launch_bounds__(kBlock)
    ViscosityListKernel(DeviceGrid grid, Particles p, const float4* __restrict__ pos,
                        const PosValue* __restrict__ pv, NeighbourList list, SeedConstants c,
                        uint32_t n) {
  __shared__ uint32_t base[kRuns][kBlock], starts[kMaxListWords][kBlock];
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const uint32_t units = list.units[i];
  if (units == 0) return;  // the grid kernel's
  const uint32_t before = ListedRuns(grid, i, base, starts);
  const float4 xi = pos[i];
  const float qx = xi.x + 0.0f, qy = xi.y + 0.0f, qz = xi.z + 0.0f;
  const float4 vi = pv[i].value;
  float sum_x = 0, sum_y = 0, sum_z = 0, sum_w = 0;  // LaneSum's running totals
  float ax = 0, ay = 0, az = 0, wsum = 0;
  ForEachListed(
      ListCursor(list, i, units, base, starts, before),
      [&](uint32_t j) {
        return PosValue{__ldg(&pv[j].pos), __ldg(&pv[j].value)};
      },
      [&] {
        sum_x += ax, sum_y += ay, sum_z += az, sum_w += wsum;
        ax = 0, ay = 0, az = 0, wsum = 0;
      },
      [&](const PosValue& nb) {
        const float4 vj = nb.value;
        float dx, dy, dz;
        const float w = c.h2 - SquaredDistance(nb.pos, qx, qy, qz, dx, dy, dz);
        const float w3 = w * w * w;
        ax += (vj.x - vi.x) * w3;
        ay += (vj.y - vi.y) * w3;
        az += (vj.z - vi.z) * w3;
        wsum += w3;
      });
  sum_x += ax, sum_y += ay, sum_z += az, sum_w += wsum;
  ApplyViscosity(p, c, i, sum_x, sum_y, sum_z, sum_w);
}

}  // namespace
}  // namespace dysa::cuda
