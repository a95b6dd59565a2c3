// The neighbour grid on the GPU: NeighborGrid (neighbor_grid.h) with the same layout, the same
// cell of every point and the same order of particles after the sort, so that the run queries
// visit the same candidates in the same order as on the CPU.
//
// The CPU sorts with a stable counting sort; the GPU with CUB's radix sort of (cell, index)
// pairs, which is stable too: particles of a cell keep their order, and the permutation is the
// same. Cell starts come from a histogram (integer atomics: the counts do not depend on the
// order they are added in) and an exclusive scan, as on the CPU.
#pragma once

#include <algorithm>
#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_reduce.cuh>
#include <cub/device/device_scan.cuh>

#include "cuda/device_buffer.cuh"
#include "cuda/gpu_types.h"

namespace dysa::cuda {

// What a kernel needs of the sorted grid: its layout, the cell starts and the sorted keys.
struct DeviceGrid {
  GridLayout layout;
  bool any_periodic = false;
  const uint32_t* cell_start = nullptr;  // cells + 1 entries
  const uint32_t* sorted_key = nullptr;  // cell of each particle, sorted order

  // NeighborGrid::CellOf, in double as there.
  __device__ uint32_t KeyOf(float px, float py, float pz) const {
    const float p[3] = {px, py, pz};
    int c[3];
    for (int a = 0; a < 3; ++a) {
      double f = (double(p[a]) - layout.origin[a]) * layout.inv_cell[a];
      const double hi = double(layout.dims[a] - 1);
      f = isnan(f) ? 0.0 : (f < 0.0 ? 0.0 : (hi < f ? hi : f));
      c[a] = static_cast<int>(f);
    }
    return uint32_t(c[0] + layout.dims[0] * (c[1] + layout.dims[1] * c[2]));
  }

  __device__ int3 SortedCell(uint32_t k) const {
    const uint32_t key = sorted_key[k];
    const uint32_t dx = uint32_t(layout.dims[0]), dy = uint32_t(layout.dims[1]);
    return make_int3(int(key % dx), int((key / dx) % dy), int(key / (dx * dy)));
  }

  // NeighborGrid::ForEachNeighborRun: visit(begin, end, shift_x, shift_y, shift_z) for each
  // non-empty run of the (2 reach + 1)^3 block around `cell`, in the same order.
  template <class Visit>
  __device__ void ForEachNeighborRun(int3 cell, Visit&& visit) const {
    const int nx = layout.dims[0], ny = layout.dims[1], nz = layout.dims[2];
    const int r = layout.reach;
    const int x0 = cell.x - r > 0 ? cell.x - r : 0;
    const int x1 = cell.x + r < nx - 1 ? cell.x + r : nx - 1;
    if (!any_periodic) {
      const int z_lo = cell.z - r > 0 ? cell.z - r : 0,
                z_hi = cell.z + r < nz - 1 ? cell.z + r : nz - 1;
      const int y_lo = cell.y - r > 0 ? cell.y - r : 0,
                y_hi = cell.y + r < ny - 1 ? cell.y + r : ny - 1;
      for (int z = z_lo; z <= z_hi; ++z) {
        for (int y = y_lo; y <= y_hi; ++y) {
          const uint32_t row = uint32_t(nx) * (y + uint32_t(ny) * z);
          const uint32_t begin = cell_start[row + x0];
          const uint32_t end = cell_start[row + x1 + 1];
          if (begin < end) visit(begin, end, 0.0f, 0.0f, 0.0f);
        }
      }
      return;
    }
    int wrap_x0 = -1, wrap_x1 = -1;
    float shift_x = 0;
    if (layout.periodic[0]) {
      if (cell.x - r < 0) {
        wrap_x0 = nx + cell.x - r, wrap_x1 = nx - 1, shift_x = layout.period[0];
      } else if (cell.x + r > nx - 1) {
        wrap_x0 = 0, wrap_x1 = cell.x + r - nx, shift_x = -layout.period[0];
      }
    }
    for (int dz = -r; dz <= r; ++dz) {
      int z = cell.z + dz;
      float shift_z = 0;
      if (!Wrap(2, z, shift_z)) continue;
      for (int dy = -r; dy <= r; ++dy) {
        int y = cell.y + dy;
        float shift_y = 0;
        if (!Wrap(1, y, shift_y)) continue;
        const uint32_t row = uint32_t(nx) * (y + uint32_t(ny) * z);
        const uint32_t begin = cell_start[row + x0];
        const uint32_t end = cell_start[row + x1 + 1];
        if (begin < end) visit(begin, end, 0.0f, shift_y, shift_z);
        if (wrap_x0 >= 0) {
          const uint32_t wrap_begin = cell_start[row + wrap_x0];
          const uint32_t wrap_end = cell_start[row + wrap_x1 + 1];
          if (wrap_begin < wrap_end) visit(wrap_begin, wrap_end, shift_x, shift_y, shift_z);
        }
      }
    }
  }

  __device__ bool Wrap(int axis, int& c, float& shift) const {
    if (c >= 0 && c < layout.dims[axis]) return true;
    if (!layout.periodic[axis]) return false;
    shift = c < 0 ? layout.period[axis] : -layout.period[axis];
    c += c < 0 ? layout.dims[axis] : -layout.dims[axis];
    return true;
  }
};

template <class Unused = void>
__global__ void CellKeyKernel(DeviceGrid grid, const float* px, const float* py, const float* pz,
                              uint32_t* key, uint32_t* index, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  key[i] = grid.KeyOf(px[i], py[i], pz[i]);
  index[i] = i;
}

template <class Unused = void>
__global__ void CellCountKernel(const uint32_t* key, uint32_t* count, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) atomicAdd(&count[key[i]], 1u);
}

// Owns the sort's buffers; Sort() leaves order() and View() valid until the next Sort().
class GridSorter {
 public:
  void Configure(const GridLayout& layout) {
    layout_ = layout;
    cells_ = uint64_t(layout.dims[0]) * layout.dims[1] * layout.dims[2];
    end_bit_ = 1;
    while (end_bit_ < 32 && (uint64_t{1} << end_bit_) < cells_) ++end_bit_;
    count_.Resize(cells_ + 1);
    cell_start_.Resize(cells_ + 1);
    size_t scan_bytes = 0;
    CheckCuda(cub::DeviceScan::ExclusiveSum(nullptr, scan_bytes, count_.data(), cell_start_.data(),
                                            int64_t(cells_ + 1)),
              "sizing the cell scan");
    size_t max_bytes = 0;
    CheckCuda(cub::DeviceReduce::Max(nullptr, max_bytes, count_.data(), max_count_.data(),
                                     int64_t(cells_ + 1)),
              "sizing the cell maximum");
    temp_.Resize(std::max<size_t>({scan_bytes, max_bytes, 1}));
    max_count_.Resize(1);
    max_count_host_.Resize(1);
    max_count_host_.data()[0] = 0;
  }

  void Reserve(uint32_t n) {
    for (DeviceBuffer<uint32_t>* b : {&key_, &key_alt_, &index_, &index_alt_}) b->Resize(n);
    cub::DoubleBuffer<uint32_t> keys(key_.data(), key_alt_.data());
    cub::DoubleBuffer<uint32_t> values(index_.data(), index_alt_.data());
    size_t sort_bytes = 0;
    CheckCuda(cub::DeviceRadixSort::SortPairs(nullptr, sort_bytes, keys, values, int64_t(n)),
              "sizing the radix sort");
    temp_.Resize(sort_bytes > 0 ? sort_bytes : 1);
  }

  void Sort(const GridLayout& layout, const float* px, const float* py, const float* pz, uint32_t n,
            cudaStream_t stream) {
    DeviceGrid grid = View();
    grid.layout = layout;
    const unsigned blocks = (n + kBlock - 1) / kBlock;
    if (n > 0) {
      CellKeyKernel<<<blocks, kBlock, 0, stream>>>(grid, px, py, pz, key_.data(), index_.data(), n);
      cub::DoubleBuffer<uint32_t> keys(key_.data(), key_alt_.data());
      cub::DoubleBuffer<uint32_t> values(index_.data(), index_alt_.data());
      size_t bytes = temp_.capacity();
      CheckCuda(cub::DeviceRadixSort::SortPairs(temp_.data(), bytes, keys, values, int64_t(n), 0,
                                                end_bit_, stream),
                "sorting particles by cell");
      sorted_key_ = keys.Current();
      order_ = values.Current();
    }
    CheckCuda(cudaMemsetAsync(count_.data(), 0, (cells_ + 1) * sizeof(uint32_t), stream),
              "clearing the cell counts");
    if (n > 0) CellCountKernel<<<blocks, kBlock, 0, stream>>>(sorted_key_, count_.data(), n);
    // The fullest cell, read by the host at the step's next synchronisation (max_count()).
    size_t max_bytes = temp_.capacity();
    CheckCuda(cub::DeviceReduce::Max(temp_.data(), max_bytes, count_.data(), max_count_.data(),
                                     int64_t(cells_ + 1), stream),
              "finding the fullest cell");
    max_count_host_.CopyFrom(max_count_, 1, stream);
    size_t bytes = temp_.capacity();
    CheckCuda(cub::DeviceScan::ExclusiveSum(temp_.data(), bytes, count_.data(), cell_start_.data(),
                                            int64_t(cells_ + 1), stream),
              "scanning the cell counts");
  }

  const uint32_t* order() const { return order_; }
  // The most particles one cell held at the latest Sort(), once the stream has synchronised
  // since (NeighborGrid::max_cell_count on the CPU).
  uint32_t max_count() const { return max_count_host_.data()[0]; }
  DeviceGrid View() const {
    DeviceGrid g;
    g.layout = layout_;
    g.any_periodic = layout_.periodic[0] || layout_.periodic[1] || layout_.periodic[2];
    g.cell_start = cell_start_.data();
    g.sorted_key = sorted_key_;
    return g;
  }
  uint64_t DeviceBytes() const {
    return uint64_t(key_.capacity()) * 4 * sizeof(uint32_t) +
           uint64_t(count_.capacity() + cell_start_.capacity()) * sizeof(uint32_t) +
           temp_.capacity();
  }

 private:
  GridLayout layout_;
  uint64_t cells_ = 1;
  int end_bit_ = 1;
  DeviceBuffer<uint32_t> key_, key_alt_, index_, index_alt_;
  DeviceBuffer<uint32_t> count_, cell_start_, max_count_;
  PinnedBuffer<uint32_t> max_count_host_;
  DeviceBuffer<unsigned char> temp_;
  const uint32_t* sorted_key_ = nullptr;
  const uint32_t* order_ = nullptr;
};

}  // namespace dysa::cuda
