// A view stream's subset on the GPU (view_subset.cuh).
#include <cuda_runtime.h>
#include <thrust/iterator/counting_iterator.h>

#include <algorithm>
#include <cstring>
#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_select.cuh>

#include "cuda/ordered_float.cuh"
#include "cuda/view_subset.cuh"
#include "dysa/view_key.h"

namespace dysa::cuda {
namespace {

// bounds[a] = min, bounds[3 + a] = max of the particles' non-NaN coordinates on axis a (as
// Ordered; NaN skipped as the host's std::min / std::max skip it). Grid-stride loop.
__global__ void BoundsKernel(SubsetParticles p, uint32_t* bounds) {
  uint32_t lo[3] = {kOrderedPlusInf, kOrderedPlusInf, kOrderedPlusInf};
  uint32_t hi[3] = {kOrderedMinusInf, kOrderedMinusInf, kOrderedMinusInf};
  const float* axis[3] = {p.x, p.y, p.z};
  for (uint32_t i = blockIdx.x * blockDim.x + threadIdx.x; i < p.n; i += gridDim.x * blockDim.x) {
    for (int a = 0; a < 3; ++a) {
      const float v = axis[a][i];
      if (v != v) continue;  // NaN
      const uint32_t o = Ordered(__float_as_uint(v));
      lo[a] = min(lo[a], o);
      hi[a] = max(hi[a], o);
    }
  }
  for (int a = 0; a < 3; ++a) {
    if (lo[a] != kOrderedPlusInf) atomicMin(&bounds[a], lo[a]);
    if (hi[a] != kOrderedMinusInf) atomicMax(&bounds[3 + a], hi[a]);
  }
}

// Each candidate's cell by candidate index, and each cell's count (integer atomics).
__global__ void CellKernel(SubsetParticles p, ViewGrid grid, uint32_t stride, uint32_t* cell_of,
                           uint32_t* counts) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= p.n) return;
  const uint32_t id = p.id[i];
  if (id % stride != 0) return;
  const uint32_t cell = ViewCellOf(grid, p.x[i], p.y[i], p.z[i]);
  cell_of[id / stride] = cell;
  atomicAdd(&counts[cell], 1u);
}

// Each candidate's key, and its index (the sort's values).
__global__ void KeyKernel(uint32_t m, uint32_t stride, const uint32_t* cell_of,
                          const double* weights, float* keys, uint32_t* candidates) {
  const uint32_t k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k >= m) return;
  keys[k] = ViewKey(k * stride, weights[cell_of[k]]);
  candidates[k] = k;
}

// The first `budget` candidates of the sorted order, flagged.
__global__ void FlagKernel(uint32_t budget, const uint32_t* sorted_candidates,
                           unsigned char* flags) {
  const uint32_t j = blockIdx.x * blockDim.x + threadIdx.x;
  if (j < budget) flags[sorted_candidates[j]] = 1;
}

// The index of `k` in the increasing list chosen[0 .. count) (which holds it).
__device__ uint32_t SlotOf(const uint32_t* chosen, uint32_t count, uint32_t k) {
  uint32_t lo = 0, hi = count;
  while (lo < hi) {
    const uint32_t mid = lo + (hi - lo) / 2;
    if (chosen[mid] < k) {
      lo = mid + 1;
    } else {
      hi = mid;
    }
  }
  return lo;
}

// Each chosen particle's values at its slot in id order: with `flags`, the flagged candidates
// (slots from the increasing list `chosen`); without, every candidate (slot id / stride). Null
// outputs are not written.
__global__ void PackChosenKernel(SubsetParticles p, uint32_t stride, const unsigned char* flags,
                                 const uint32_t* chosen, uint32_t count, float* position,
                                 float* velocity, float* density) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= p.n) return;
  const uint32_t id = p.id[i];
  if (id % stride != 0) return;
  const uint32_t k = id / stride;
  if (flags && !flags[k]) return;
  const size_t j = flags ? SlotOf(chosen, count, k) : k;
  if (position) {
    position[3 * j] = p.x[i];
    position[3 * j + 1] = p.y[i];
    position[3 * j + 2] = p.z[i];
  }
  if (velocity) {
    velocity[3 * j] = p.vx[i];
    velocity[3 * j + 1] = p.vy[i];
    velocity[3 * j + 2] = p.vz[i];
  }
  if (density) density[j] = p.density[i];
}

unsigned Blocks(uint64_t n) { return unsigned((n + kBlock - 1) / kBlock); }

}  // namespace

ViewGrid ViewSubset::Grid(const SubsetParticles& p, const ViewSubsetRequest& request,
                          cudaStream_t stream) {
  double particle_min[3], particle_max[3];
  bool degenerate = false;
  for (int a = 0; a < 3; ++a) {
    particle_min[a] = double(FromOrdered(kOrderedPlusInf));
    particle_max[a] = double(FromOrdered(kOrderedMinusInf));
    degenerate |= !(request.box_max[a] > request.box_min[a]);
  }
  if (degenerate && p.n > 0) {
    bounds_.Resize(6);
    host_bounds_.Resize(6);
    uint32_t* host = host_bounds_.data();
    for (int a = 0; a < 3; ++a) host[a] = kOrderedPlusInf, host[3 + a] = kOrderedMinusInf;
    CheckCuda(
        cudaMemcpyAsync(bounds_.data(), host, 6 * sizeof(uint32_t), cudaMemcpyHostToDevice, stream),
        "uploading a view's bounds");
    BoundsKernel<<<std::min(Blocks(p.n), 1024u), kBlock, 0, stream>>>(p, bounds_.data());
    host_bounds_.CopyFrom(bounds_, 6, stream);
    CheckCuda(cudaStreamSynchronize(stream), "bounding a view's particles");
    for (int a = 0; a < 3; ++a) {
      particle_min[a] = double(FromOrdered(host[a]));
      particle_max[a] = double(FromOrdered(host[3 + a]));
    }
  }
  return MakeViewGrid(request.box_min.data(), request.box_max.data(), particle_min, particle_max,
                      p.n);
}

void ViewSubset::Choose(const SubsetParticles& p, const ViewSubsetRequest& request, uint32_t stride,
                        uint32_t m, uint32_t budget, cudaStream_t stream) {
  const ViewGrid grid = Grid(p, request, stream);
  // Cells and counts; the counts to the host.
  cell_of_.Resize(m);
  counts_.Resize(kViewCells);
  host_counts_.Resize(kViewCells);
  CheckCuda(cudaMemsetAsync(counts_.data(), 0, kViewCells * sizeof(uint32_t), stream),
            "zeroing a view's counts");
  CellKernel<<<Blocks(p.n), kBlock, 0, stream>>>(p, grid, stride, cell_of_.data(), counts_.data());
  host_counts_.CopyFrom(counts_, kViewCells, stream);
  CheckCuda(cudaStreamSynchronize(stream), "counting a view's cells");
  // The weights, on the host (the camera's maths), to the device.
  host_weights_.Resize(kViewCells);
  std::fill(host_weights_.data(), host_weights_.data() + kViewCells, 0.0);
  request.weigh(grid, host_counts_.data(), host_weights_.data());
  weights_.Resize(kViewCells);
  CheckCuda(cudaMemcpyAsync(weights_.data(), host_weights_.data(), kViewCells * sizeof(double),
                            cudaMemcpyHostToDevice, stream),
            "uploading a view's weights");
  // Keys, sorted with their candidate index (stable: ties keep k order).
  keys_.Resize(m);
  sorted_keys_.Resize(m);
  candidates_.Resize(m);
  sorted_candidates_.Resize(m);
  flags_.Resize(m);
  chosen_.Resize(budget);
  chosen_count_.Resize(1);
  KeyKernel<<<Blocks(m), kBlock, 0, stream>>>(m, stride, cell_of_.data(), weights_.data(),
                                              keys_.data(), candidates_.data());
  size_t sort_bytes = 0, select_bytes = 0;
  const thrust::counting_iterator<uint32_t> indices(0);
  CheckCuda(cub::DeviceRadixSort::SortPairs(nullptr, sort_bytes, keys_.data(), sorted_keys_.data(),
                                            candidates_.data(), sorted_candidates_.data(), m, 0, 32,
                                            stream),
            "sizing a view's sort");
  CheckCuda(cub::DeviceSelect::Flagged(nullptr, select_bytes, indices, flags_.data(),
                                       chosen_.data(), chosen_count_.data(), int64_t(m), stream),
            "sizing a view's selection");
  temp_.Resize(std::max<size_t>({sort_bytes, select_bytes, 1}));
  CheckCuda(cub::DeviceRadixSort::SortPairs(temp_.data(), sort_bytes, keys_.data(),
                                            sorted_keys_.data(), candidates_.data(),
                                            sorted_candidates_.data(), m, 0, 32, stream),
            "sorting a view's keys");
  // The budget's candidates, flagged, compacted in increasing k.
  CheckCuda(cudaMemsetAsync(flags_.data(), 0, m, stream), "zeroing a view's flags");
  FlagKernel<<<Blocks(budget), kBlock, 0, stream>>>(budget, sorted_candidates_.data(),
                                                    flags_.data());
  CheckCuda(cub::DeviceSelect::Flagged(temp_.data(), select_bytes, indices, flags_.data(),
                                       chosen_.data(), chosen_count_.data(), int64_t(m), stream),
            "selecting a view's particles");
}

RankSubsetCopy ViewSubset::Download(const SubsetParticles& p, const ViewSubsetRequest& request,
                                    uint64_t budget, bool position, bool velocity, bool density,
                                    cudaStream_t stream) {
  const uint32_t stride = std::max<uint32_t>(1, request.stride);
  const auto m = uint32_t((uint64_t(p.n) + stride - 1) / stride);
  const auto count = uint32_t(std::min<uint64_t>(budget, m));
  RankSubsetCopy copy;
  host_ids_.resize(count);
  if (count == 0) return copy;
  const bool every = count == m;  // every candidate: no grid, no weights, no sort
  if (!every) Choose(p, request, stride, m, count, stream);
  // One buffer: [positions 3c][velocities 3c][densities c], the parts asked for.
  const size_t c = count;
  const size_t position_at = 0;
  const size_t velocity_at = position_at + (position ? 3 * c : 0);
  const size_t density_at = velocity_at + (velocity ? 3 * c : 0);
  const size_t floats = density_at + (density ? c : 0);
  if (floats > 0) {
    packed_.Resize(floats);
    host_packed_.Resize(floats);
    float* out = packed_.data();
    PackChosenKernel<<<Blocks(p.n), kBlock, 0, stream>>>(
        p, stride, every ? nullptr : flags_.data(), every ? nullptr : chosen_.data(), count,
        position ? out + position_at : nullptr, velocity ? out + velocity_at : nullptr,
        density ? out + density_at : nullptr);
    host_packed_.CopyFrom(packed_, floats, stream);
  }
  if (!every) {
    host_chosen_.Resize(c);
    host_chosen_.CopyFrom(chosen_, c, stream);
  }
  CheckCuda(cudaStreamSynchronize(stream), "downloading a view's subset");
  for (uint32_t j = 0; j < count; ++j) host_ids_[j] = (every ? j : host_chosen_.data()[j]) * stride;
  copy.count = c;
  copy.ids = host_ids_.data();
  const float* host = host_packed_.data();
  if (position) copy.position = host + position_at;
  if (velocity) copy.velocity = host + velocity_at;
  if (density) copy.density = host + density_at;
  return copy;
}

uint64_t ViewSubset::DeviceBytes() const {
  return uint64_t(bounds_.capacity() + cell_of_.capacity() + counts_.capacity() +
                  candidates_.capacity() + sorted_candidates_.capacity() + chosen_.capacity()) *
             sizeof(uint32_t) +
         uint64_t(weights_.capacity()) * sizeof(double) +
         uint64_t(keys_.capacity() + sorted_keys_.capacity() + packed_.capacity()) * sizeof(float) +
         flags_.capacity() + chosen_count_.capacity() * sizeof(int64_t) + temp_.capacity();
}

}  // namespace dysa::cuda
