// The seed pipeline's neighbour list (seed_pipeline.cu): its layout, its writer's word stores
// and its readers' cursor over a listed particle's neighbours, in list order.
#pragma once

#include <cuda_runtime.h>

#include <cstdint>

#include "cuda/device_buffer.cuh"
#include "cuda/device_grid.cuh"

namespace dysa::cuda {
// Each file that includes this gets its own copy of these functions.
namespace {

constexpr int kLanes = 8;  // the CPU's vector width (simd.h), kept as 8 register partial sums

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

}  // namespace
}  // namespace dysa::cuda
