// The level of detail's subset on the GPU (rank_subset.cuh).
#include <cuda_runtime.h>
#include <thrust/iterator/counting_iterator.h>

#include <cub/device/device_select.cuh>

#include "cuda/rank_subset.cuh"
#include "dysa/detail_rank.h"

namespace dysa::cuda {
namespace {

struct KeptByRank {
  uint32_t threshold;
  __host__ __device__ bool operator()(uint32_t id) const { return BelowRank(id, threshold); }
};

// count += the ids below n that the threshold keeps (integer atomics: any order, same sum).
__global__ void CountKeptKernel(uint32_t n, uint32_t threshold, uint32_t* count) {
  const uint32_t id = blockIdx.x * blockDim.x + threadIdx.x;
  const int kept = __syncthreads_count(id < n && BelowRank(id, threshold));
  if (threadIdx.x == 0 && kept > 0) atomicAdd(count, uint32_t(kept));
}

// The index of `id` in the increasing table kept[0 .. k) (which holds it).
__device__ uint32_t SlotOf(const uint32_t* kept, uint32_t k, uint32_t id) {
  uint32_t lo = 0, hi = k;
  while (lo < hi) {
    const uint32_t mid = lo + (hi - lo) / 2;
    if (kept[mid] < id) {
      lo = mid + 1;
    } else {
      hi = mid;
    }
  }
  return lo;
}

// Each kept particle's values at its slot in id order; null outputs are not written.
__global__ void PackKeptKernel(SubsetParticles p, uint32_t threshold, const uint32_t* kept,
                               uint32_t k, float* position, float* velocity, float* density) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= p.n) return;
  const uint32_t id = p.id[i];
  if (!BelowRank(id, threshold)) return;
  const size_t j = SlotOf(kept, k, id);
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

unsigned Blocks(uint32_t n) { return (n + kBlock - 1) / kBlock; }

}  // namespace

void RankSubset::BuildTable(uint32_t n, uint32_t threshold, cudaStream_t stream) {
  cached_ = false;
  host_kept_.clear();
  if (n > 0) {
    count_.Resize(1);
    host_count_.Resize(1);
    CheckCuda(cudaMemsetAsync(count_.data(), 0, sizeof(uint32_t), stream), "counting a subset");
    CountKeptKernel<<<Blocks(n), kBlock, 0, stream>>>(n, threshold, count_.data());
    host_count_.CopyFrom(count_, 1, stream);
    CheckCuda(cudaStreamSynchronize(stream), "counting a subset");
    host_kept_.resize(host_count_.data()[0]);
  }
  if (!host_kept_.empty()) {
    kept_.Resize(host_kept_.size());
    const thrust::counting_iterator<uint32_t> ids(0);
    size_t bytes = 0;
    CheckCuda(cub::DeviceSelect::If(nullptr, bytes, ids, kept_.data(), count_.data(), int64_t(n),
                                    KeptByRank{threshold}, stream),
              "sizing a subset's selection");
    temp_.Resize(bytes > 0 ? bytes : 1);
    CheckCuda(cub::DeviceSelect::If(temp_.data(), bytes, ids, kept_.data(), count_.data(),
                                    int64_t(n), KeptByRank{threshold}, stream),
              "selecting a subset");
    kept_.CopyTo(host_kept_.data(), host_kept_.size(), stream);
    CheckCuda(cudaStreamSynchronize(stream), "selecting a subset");
  }
  cached_ = true;
  table_n_ = n;
  table_threshold_ = threshold;
}

RankSubsetCopy RankSubset::Download(const SubsetParticles& p, uint32_t threshold, bool position,
                                    bool velocity, bool density, cudaStream_t stream) {
  if (!cached_ || table_n_ != p.n || table_threshold_ != threshold) {
    BuildTable(p.n, threshold, stream);
  }
  const size_t k = host_kept_.size();
  RankSubsetCopy copy;
  copy.count = k;
  copy.ids = host_kept_.data();
  if (k == 0) return copy;
  // One buffer: [positions 3k][velocities 3k][densities k], the parts asked for.
  const size_t position_at = 0;
  const size_t velocity_at = position_at + (position ? 3 * k : 0);
  const size_t density_at = velocity_at + (velocity ? 3 * k : 0);
  const size_t floats = density_at + (density ? k : 0);
  if (floats == 0) return copy;
  packed_.Resize(floats);
  host_packed_.Resize(floats);
  float* out = packed_.data();
  PackKeptKernel<<<Blocks(p.n), kBlock, 0, stream>>>(
      p, threshold, kept_.data(), uint32_t(k), position ? out + position_at : nullptr,
      velocity ? out + velocity_at : nullptr, density ? out + density_at : nullptr);
  host_packed_.CopyFrom(packed_, floats, stream);
  CheckCuda(cudaStreamSynchronize(stream), "downloading a subset");
  const float* host = host_packed_.data();
  if (position) copy.position = host + position_at;
  if (velocity) copy.velocity = host + velocity_at;
  if (density) copy.density = host + density_at;
  return copy;
}

uint64_t RankSubset::DeviceBytes() const {
  return uint64_t(kept_.capacity() + count_.capacity()) * sizeof(uint32_t) + temp_.capacity() +
         uint64_t(packed_.capacity()) * sizeof(float);
}

}  // namespace dysa::cuda
