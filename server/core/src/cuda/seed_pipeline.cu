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
#include "cuda/probe_gatherer.cuh"
#include "cuda/rank_subset.cuh"
#include "cuda/seed_pipeline.h"
#include "cuda/view_subset.cuh"

namespace dysa::cuda {
namespace {

constexpr int kLanes = 8;  // the CPU's vector width (simd.h), kept as 8 register partial sums

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

// The neighbour list (runs without periodic axes): the density pass scans the 27 cells once, as
// the grid kernel does, and records which candidates lie within h (those at distance 0
// included); the pressure and viscosity passes, which would scan the same candidates around the
// same predicted positions (about 5 per neighbour), visit only those.
//
// The record is a bit mask. A particle's candidates go in blocks of 8, the CPU's vectors: block
// t counts on across its runs (NeighbourRun 0..8, empty ones skipped; run r's blocks are
// begin_r + 8 b), and the candidate of lane l in block t is bit t of lane l's mask. A lane's mask
// is stored in 32-bit words, word w holding blocks 32 w .. 32 w + 31: lane l's word w of particle
// i at (8 w + l) * stride + i (8 coalesced stores for a warp's 32 blocks, one coalesced load per
// word read). `units` says which words hold a neighbour (bit 4 l + w), so that a reader loads
// only those, in the order of the bits: lane 0's words, then lane 1's, and so on. The list is
// thus lane-major, each lane's neighbours in candidate order, and a thread adds each lane's terms
// into one register and the lane into the total when the next lane starts. That is LaneSum's
// order (lanes without neighbours would add +0 to a sum that is never -0: skipping them changes
// nothing, as in seed_pipeline.h), with no indexing into 8 partial sums.
//
// A bit turns back into a particle index through the run that holds its block: a reader keeps,
// in shared memory, its runs' first particles less 8 times their first blocks (`base`, one per
// non-empty run) and, per word, the blocks where runs start (`starts`); the run of block t is
// the count of starts up to t, less one.
//
// A particle with more blocks than the capacity (at most kMaxListWords words per lane) is left
// to the grid kernels (Overflow); the step reports how many there were, and the host grows the
// list by a word per lane while more than one particle in 1,024 does not fit.
constexpr int kRuns = 9;
constexpr uint32_t kMaxListWords = 4;  // words per lane: 128 blocks, 1,024 candidates
constexpr uint32_t kBlocksPerWord = 32;

struct NeighbourList {
  uint32_t* word;   // lane l's word w of particle i at (8 w + l) * stride + i
  uint32_t* units;  // per particle, bit 4 l + w: lane l's word w has a neighbour; 0: not listed
  uint64_t stride;
  uint32_t words;     // words per lane, 1..kMaxListWords
  uint32_t capacity;  // the most blocks of a listed particle, at most 32 * words

  __device__ uint64_t At(uint32_t lane, uint32_t w, uint32_t i) const {
    return uint64_t(kLanes * w + lane) * stride + i;
  }
};

// The particles the grid kernels compute: all of them without a list (units null), otherwise
// those the list kernels left (more blocks than the capacity).
struct Overflow {
  const uint32_t* units;
  __device__ bool Skip(uint32_t i) const { return units != nullptr && units[i] != 0; }
};

struct Densities {
  float *density, *near_density, *pressure, *near_pressure;
};

// Run r (0..8) of DeviceGrid::ForEachNeighborRun without periodic axes, in its order: run
// 3 (dz + 1) + (dy + 1) is the row (y + dy, z + dz), empty where that row lies outside the grid.
__device__ __forceinline__ void NeighbourRun(const DeviceGrid& grid, int3 cell, int r,
                                             uint32_t& begin, uint32_t& end) {
  const int nx = grid.layout.dims[0], ny = grid.layout.dims[1], nz = grid.layout.dims[2];
  const int z = cell.z + r / 3 - 1, y = cell.y + r % 3 - 1;
  begin = end = 0;
  if (z >= 0 && z < nz && y >= 0 && y < ny) {
    const int x0 = cell.x > 0 ? cell.x - 1 : 0;
    const int x1 = cell.x + 1 < nx ? cell.x + 1 : nx - 1;
    const uint32_t row = uint32_t(nx) * (y + uint32_t(ny) * z);
    begin = grid.cell_start[row + x0];
    end = grid.cell_start[row + x1 + 1];
  }
}

// Stores lane_bits as the lanes' word w (those with a neighbour, if the list has a word w),
// marks them in units, and clears lane_bits for the next word.
__device__ __forceinline__ void StoreListWords(const NeighbourList& list, uint32_t i, uint32_t w,
                                               uint32_t lane_bits[kLanes], uint32_t& units) {
  if (w < list.words) {
#pragma unroll
    for (uint32_t l = 0; l < kLanes; ++l) {
      if (lane_bits[l] == 0) continue;
      list.word[list.At(l, w, i)] = lane_bits[l];
      units |= 1u << (kMaxListWords * l + w);
    }
  }
#pragma unroll
  for (int l = 0; l < kLanes; ++l) lane_bits[l] = 0;
}

// A listed particle's runs, for ForEachListed: fills base (the k-th non-empty run's first
// particle less 8 times its first block) and starts (bit t % 32 of word t / 32: a run starts at
// block t); returns nibble w: the count of runs that start before word w.
__device__ uint32_t ListedRuns(const DeviceGrid& grid, uint32_t i, uint32_t (*base)[kBlock],
                               uint32_t (*starts)[kBlock]) {
  const int3 cell = grid.SortedCell(i);
#pragma unroll
  for (uint32_t w = 0; w < kMaxListWords; ++w) starts[w][threadIdx.x] = 0;
  uint32_t t = 0, k = 0, before = 0;
#pragma unroll
  for (int r = 0; r < kRuns; ++r) {
    uint32_t begin, end;
    NeighbourRun(grid, cell, r, begin, end);
    const uint32_t blocks = (end - begin + kLanes - 1) / kLanes;
    if (blocks == 0) continue;
    // t < 32 * kMaxListWords: a listed particle has at most that many blocks.
    const uint32_t w = t / kBlocksPerWord;
    base[k++][threadIdx.x] = begin - kLanes * t;
    starts[w][threadIdx.x] |= 1u << (t % kBlocksPerWord);
    before += 0x1111u << (4 * (w + 1));  // one more run before each later word
    t += blocks;
  }
  return before;
}

// Walks listed particle i's neighbours (units: list.units[i], not 0) in list order; base, starts
// and before from ListedRuns. The word after the current one is loaded, and its run starts read,
// one word ahead.
class ListCursor {
 public:
  __device__ ListCursor(const NeighbourList& list, uint32_t i, uint32_t units,
                        const uint32_t (*base)[kBlock], const uint32_t (*starts)[kBlock],
                        uint32_t before)
      : words_(list.word + i),
        stride_(list.stride),
        units_(units),
        base_(base),
        starts_(starts),
        before_(before) {
    Take(unit_, bits_, run_starts_);
    Take(next_unit_, next_bits_, next_starts_);
    lane_ = unit_ / kMaxListWords;
    EnterWord();
  }

  // The next neighbour j, false after the last; new_lane: j is the first of a lane after another
  // lane's.
  __device__ bool Next(uint32_t& j, bool& new_lane) {
    new_lane = false;
    if (bits_ == 0) {
      if (next_bits_ == 0) return false;
      unit_ = next_unit_, bits_ = next_bits_, run_starts_ = next_starts_;
      new_lane = unit_ / kMaxListWords != lane_;
      lane_ = unit_ / kMaxListWords;
      EnterWord();
      Take(next_unit_, next_bits_, next_starts_);
    }
    const uint32_t b = __ffs(bits_) - 1;  // block 32 w + b
    bits_ &= bits_ - 1;
    const uint32_t k = runs_before_ + __popc(run_starts_ & ((2u << b) - 1)) - 1;
    j = base_[k][threadIdx.x] + first_ + kLanes * b;
    return true;
  }

 private:
  // Takes the next unit (lane, word) from units_; bits 0 when none is left.
  __device__ void Take(uint32_t& unit, uint32_t& bits, uint32_t& run_starts) {
    bits = 0;
    if (units_ == 0) return;
    unit = __ffs(units_) - 1;
    units_ &= units_ - 1;
    const uint32_t w = unit % kMaxListWords;
    bits = __ldg(words_ + (kLanes * w + unit / kMaxListWords) * stride_);  // NeighbourList::At
    run_starts = starts_[w][threadIdx.x];
  }

  __device__ void EnterWord() {
    const uint32_t w = unit_ % kMaxListWords;
    runs_before_ = (before_ >> (4 * w)) & 15;
    first_ = kLanes * kBlocksPerWord * w + lane_;  // lane's candidate in block 32 w, less base
  }

  const uint32_t* words_;  // the particle's first word
  uint64_t stride_;
  uint32_t units_;
  const uint32_t (*base_)[kBlock];
  const uint32_t (*starts_)[kBlock];
  uint32_t before_;
  uint32_t unit_ = 0, bits_ = 0, run_starts_ = 0;
  uint32_t next_unit_ = 0, next_bits_ = 0, next_starts_ = 0;
  uint32_t lane_ = 0, runs_before_ = 0, first_ = 0;
};

// Visits a listed particle's neighbours in list order: use(load(j)) for each neighbour j, with
// next_lane() where a lane's neighbours end and another's begin. One flat loop over the
// neighbours, so that a warp's threads visit their k-th neighbours together (a loop per word
// would wait, word by word, for the thread with the most), and load(j) one neighbour ahead, so
// that a thread's loads of the next neighbour fly while it computes the current one.
template <class Load, class NextLane, class Use>
__device__ __forceinline__ void ForEachListed(ListCursor cursor, Load&& load, NextLane&& next_lane,
                                              Use&& use) {
  uint32_t j = 0, next_j = 0;
  bool new_lane = false, next_new_lane = false;
  cursor.Next(j, new_lane);  // a listed particle has a neighbour: itself
  auto data = load(j);
  for (;;) {
    const bool more = cursor.Next(next_j, next_new_lane);
    const auto next_data = load(more ? next_j : j);
    if (new_lane) next_lane();
    use(data);
    if (!more) break;
    data = next_data, new_lane = next_new_lane;
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

struct SeedPipeline::Impl {
  explicit Impl(int device_index) : device(device_index), stream(device_index) {
    // DYSA_CUDA_SEED_LIST=K fixes the neighbour list's capacity at K blocks of 8 candidates per
    // particle (0: no list, the grid kernels only; a small K leaves most particles to them), for
    // tests of the grid kernels and the overflow path.
    if (const char* value = std::getenv("DYSA_CUDA_SEED_LIST")) {
      const unsigned long k = std::strtoul(value, nullptr, 10);
      list_want = uint32_t(std::min<unsigned long>(k, kMaxListBlocks));
      list_fixed = true;
    }
  }

  // The neighbour list's capacity, blocks of 8 candidates per particle: the first (2 words per
  // lane, 68 bytes a particle with the units: the ~40-50 blocks of the thesis fluid's 10M and
  // 100M blocks) and the most it grows to (132 bytes: twice the ~65 blocks of its 1M block).
  static constexpr uint32_t kListBlocks = 2 * kBlocksPerWord;
  static constexpr uint32_t kMaxListBlocks = kMaxListWords * kBlocksPerWord;

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
  mutable ProbeGatherer probe_gatherer;
  mutable RankSubset rank_subset;  // DownloadBelowRank's
  mutable ViewSubset view_subset;  // DownloadViewSubset's
  DeviceBuffer<float> density, near_density, pressure, near_pressure;
  // The grid's points (px, py, pz), for the neighbour kernels, and kLanes - 1 entries of
  // padding (DensityListKernel loads whole blocks).
  DeviceBuffer<float4> pos4;
  DeviceBuffer<PosValue> pos_value;  // the points with the pressure factors; with the velocities
  DeviceBuffer<uint32_t> list_words;
  DeviceBuffer<uint32_t> list_units;
  uint32_t list_want = kListBlocks;  // the capacity (blocks) the next step asks for
  bool list_fixed = false;           // DYSA_CUDA_SEED_LIST: no growth
  bool list_refused = false;         // no room for list_want; not asked again until Upload
  GridSorter sorter;
  DeviceBuffer<SphereObstacle> spheres;
  DeviceBuffer<BoxObstacle> boxes;
  // Copied back per step: [0] limited, [1] non-finite, [2] the particles the list could not
  // hold.
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
    pos4.Resize(uint64_t(count) + kLanes - 1);
    CheckCuda(cudaMemsetAsync(pos4.data() + count, 0, (kLanes - 1) * sizeof(float4), stream.get()),
              "clearing the positions' padding");
    pos_value.Resize(count);
    list_units.Resize(count);
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

  // Word w of a particle's lane l lies (8 w + l) * ListStride() words after its first; rounded
  // up so that a warp's words start on a 128-byte line.
  uint64_t ListStride() const { return RoundUp(n, 32); }

  // The list for this step (capacity 0 for the grid kernels: periodic axes, as the list does not
  // carry the runs' shifts, or no room). It takes at most half the GPU memory free besides it;
  // without room for list_want, it keeps the words it has.
  NeighbourList PrepareList() {
    NeighbourList list{list_words.data(), list_units.data(), ListStride(), 0, 0};
    const GridLayout& g = config.grid;
    if (n == 0 || list_want == 0 || g.periodic[0] || g.periodic[1] || g.periodic[2] ||
        !(config.constants.h2 > 0)) {
      return list;
    }
    const uint64_t per_word = kLanes * list.stride;  // a word of every lane of every particle
    const uint64_t words = (list_want + kBlocksPerWord - 1) / kBlocksPerWord;
    if (list_words.capacity() < words * per_word && !list_refused) {
      size_t free = 0, total = 0;
      CheckCuda(cudaMemGetInfo(&free, &total), "reading the free GPU memory");
      const uint64_t own = list_words.capacity() * sizeof(uint32_t);
      if (words * per_word * sizeof(uint32_t) <= (free + own) / 2) {
        try {
          list_words.Resize(words * per_word);
        } catch (const std::runtime_error&) {
          cudaGetLastError();  // clears the failed allocation's error: the grid kernels go on
        }
      }
      list_refused = list_words.capacity() < words * per_word;
    }
    list.word = list_words.data();
    list.words = uint32_t(std::min<uint64_t>(words, list_words.capacity() / per_word));
    list.capacity = std::min(list_want, list.words * kBlocksPerWord);
    return list;
  }

  // After a step in which more than one particle in 1,024 did not fit (their pressure force and
  // viscosity take the grid kernels, whose warps cost as much for one such particle as for 32),
  // a word more per lane for the next steps, up to kMaxListBlocks; the rest stay with the grid.
  void GrowList(uint32_t capacity, uint64_t unlisted) {
    if (capacity == 0 || list_fixed || list_refused || unlisted <= n / 1024) return;
    list_want = std::min(uint32_t(RoundUp(capacity + 1, kBlocksPerWord)), kMaxListBlocks);
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

void SeedPipeline::MoveObstacles(const std::vector<SphereObstacle>& spheres,
                                 const std::vector<BoxObstacle>& boxes) {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  m.spheres.Assign(spheres, m.stream.get());
  m.boxes.Assign(boxes, m.stream.get());
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
  const NeighbourList list = launch ? m.PrepareList() : NeighbourList{};
  const uint32_t capacity = list.capacity;
  // With a list, the grid kernels compute only the pressure force and viscosity of the particles
  // it could not hold.
  const Overflow overflow{capacity > 0 ? list.units : nullptr};
  const Densities densities{m.density.data(), m.near_density.data(), m.pressure.data(),
                            m.near_pressure.data()};
  const float4* pos = m.pos4.data();
  PosValue* pv = m.pos_value.data();

  begin_pass();  // external_forces
  if (launch) {
    ExternalForcesKernel<<<blocks, kBlock, 0, s>>>(m.View(), n, cfg.gravity_dv, cfg.lookahead);
  }
  begin_pass();  // neighbour_grid
  m.Sort();
  const DeviceGrid grid = m.sorter.View();
  begin_pass();  // density
  if (launch) {
    unsigned long long* unlisted = m.device_flags.data() + 2;
    if (capacity > 0) {
      if (cfg.near) {
        DensityListKernel<true>
            <<<blocks, kBlock, 0, s>>>(grid, pos, list, densities, c, unlisted, n);
      } else {
        DensityListKernel<false>
            <<<blocks, kBlock, 0, s>>>(grid, pos, list, densities, c, unlisted, n);
      }
    } else if (cfg.near) {
      DensityKernel<true><<<blocks, kBlock, 0, s>>>(grid, pos, densities, c, n);
    } else {
      DensityKernel<false><<<blocks, kBlock, 0, s>>>(grid, pos, densities, c, n);
    }
  }
  begin_pass();  // pressure_force
  if (launch) {
    PressureFactorsKernel<<<blocks, kBlock, 0, s>>>(pos, m.density.data(), m.pressure.data(),
                                                    m.near_pressure.data(), pv, n, cfg.near);
    const Particles p = m.View();
    const float* pr = m.pressure.data();
    const float* near_pr = m.near_pressure.data();
    if (cfg.near) {
      if (capacity > 0) {
        PressureForceListKernel<true>
            <<<blocks, kBlock, 0, s>>>(grid, p, pos, pr, near_pr, pv, list, c, n);
      }
      PressureForceKernel<true>
          <<<blocks, kBlock, 0, s>>>(grid, p, pos, pr, near_pr, pv, c, overflow, n);
    } else {
      if (capacity > 0) {
        PressureForceListKernel<false>
            <<<blocks, kBlock, 0, s>>>(grid, p, pos, pr, near_pr, pv, list, c, n);
      }
      PressureForceKernel<false>
          <<<blocks, kBlock, 0, s>>>(grid, p, pos, pr, near_pr, pv, c, overflow, n);
    }
  }
  if (cfg.viscosity) {
    begin_pass();  // viscosity
    if (launch) {
      PackVelocityKernel<<<blocks, kBlock, 0, s>>>(m.View(), pos, pv, n);
      if (capacity > 0) {
        ViscosityListKernel<<<blocks, kBlock, 0, s>>>(grid, m.View(), pos, pv, list, c, n);
      }
      ViscosityKernel<<<blocks, kBlock, 0, s>>>(grid, m.View(), pos, pv, c, overflow, n);
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

void SeedPipeline::GatherProbes(const ProbeGatherPlan& plan, ProbeGather& out) const {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  m.probe_gatherer.Gather(ProbeParticlesOf(m), plan, m.stream.get(), out);
}

RankSubsetCopy SeedPipeline::DownloadBelowRank(uint32_t threshold, bool position, bool velocity,
                                               bool density) const {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  return m.rank_subset.Download(SubsetParticlesOf(m), threshold, position, velocity, density,
                                m.stream.get());
}

RankSubsetCopy SeedPipeline::DownloadViewSubset(const ViewSubsetRequest& request, uint64_t budget,
                                                bool position, bool velocity, bool density) const {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  return m.view_subset.Download(SubsetParticlesOf(m), request, budget, position, velocity, density,
                                m.stream.get());
}

uint32_t SeedPipeline::max_cell_count() const { return impl_->sorter.max_count(); }

uint64_t SeedPipeline::DeviceBytes() const {
  const Impl& m = *impl_;
  // 22 float arrays (positions, velocities, predictions, their permutation targets, densities,
  // pressures), two id arrays, the packed positions (float4) and the positions with values (two
  // float4), the neighbour list's units and words, and the grid's keys, order and cell starts.
  return uint64_t(m.x.capacity()) * (22 * sizeof(float) + 2 * sizeof(uint32_t)) +
         uint64_t(m.pos4.capacity()) * sizeof(float4) +
         uint64_t(m.pos_value.capacity()) * sizeof(PosValue) +
         uint64_t(m.list_units.capacity() + m.list_words.capacity()) * sizeof(uint32_t) +
         m.sorter.DeviceBytes() + m.rank_subset.DeviceBytes() + m.view_subset.DeviceBytes();
}

}  // namespace dysa::cuda
