// Order-free sums on the device: each term rounded to a 64-bit fixed-point integer on its own
// (dysa/core/fixed_point.h, the CPU's ToFixedPoint repeated here), the integers reduced in
// blocks. Integers add exactly in any order, so the total is the CPU's FixedPointSum bit for bit.
#pragma once

#include <cuda_runtime.h>

#include <cstdint>

#include "cuda/device_buffer.cuh"
#include "dysa/core/fixed_point.h"

namespace dysa::cuda {
namespace {

// PartialFixedPointSumKernel: block b sums values[k] * factor over its contiguous chunk
// [b chunk, (b + 1) chunk) into partial[b], leaving out k where skip is set and skip[k] != 0
// (the ghosts of one of several processes: FixedPointSum's skip); FinalFixedPointSumKernel adds
// the `count` partials.
constexpr unsigned kSumBlocks = 512;
constexpr unsigned kSumThreads = 256;
__device__ long long ToFixedPointOnDevice(double term) {
  if (isnan(term)) term = dysa::kFixedPointMaxTerm;
  if (term > dysa::kFixedPointMaxTerm) term = dysa::kFixedPointMaxTerm;
  if (term < -dysa::kFixedPointMaxTerm) term = -dysa::kFixedPointMaxTerm;
  return llround(term * dysa::kFixedPointScale);
}
__global__ void PartialFixedPointSumKernel(const float* values, const uint8_t* skip, uint32_t n,
                                           uint32_t chunk, double factor, long long* partial) {
  __shared__ long long tree[kSumThreads];
  const uint32_t lo = blockIdx.x * chunk;
  const uint32_t hi = lo + chunk < n ? lo + chunk : n;
  long long sum = 0;
  for (uint32_t k = lo + threadIdx.x; k < hi; k += kSumThreads) {
    if (skip && skip[k]) continue;
    sum += ToFixedPointOnDevice(double(values[k]) * factor);
  }
  tree[threadIdx.x] = sum;
  __syncthreads();
  for (unsigned half = kSumThreads / 2; half > 0; half /= 2) {
    if (threadIdx.x < half) tree[threadIdx.x] += tree[threadIdx.x + half];
    __syncthreads();
  }
  if (threadIdx.x == 0) partial[blockIdx.x] = tree[0];
}
__global__ void FinalFixedPointSumKernel(const long long* partial, unsigned count, long long* out) {
  __shared__ long long tree[kSumBlocks];
  tree[threadIdx.x] = threadIdx.x < count ? partial[threadIdx.x] : 0;
  __syncthreads();
  for (unsigned half = kSumBlocks / 2; half > 0; half /= 2) {
    if (threadIdx.x < half) tree[threadIdx.x] += tree[threadIdx.x + half];
    __syncthreads();
  }
  if (threadIdx.x == 0) *out = tree[0];
}

// The fixed-point sum of values[k] * factor over k < n (n > 0) not skipped, on stream `s`: the
// blocks' partial sums in `partial` (kSumBlocks of them), the total into `device_total` and from
// there into page-locked `host_total`; returns it once the stream has passed.
inline long long DeviceFixedPointSum(const float* values, const uint8_t* skip, uint32_t n,
                                     double factor, long long* partial, long long* device_total,
                                     long long* host_total, cudaStream_t s) {
  const uint32_t chunk = (n + kSumBlocks - 1) / kSumBlocks;
  const unsigned blocks = (n + chunk - 1) / chunk;
  PartialFixedPointSumKernel<<<blocks, kSumThreads, 0, s>>>(values, skip, n, chunk, factor,
                                                            partial);
  FinalFixedPointSumKernel<<<1, kSumBlocks, 0, s>>>(partial, blocks, device_total);
  CheckCuda(cudaMemcpyAsync(host_total, device_total, sizeof(long long), cudaMemcpyDeviceToHost, s),
            "reading a sum");
  CheckCuda(cudaStreamSynchronize(s), "summing as fixed-point integers");
  return *host_total;
}

}  // namespace
}  // namespace dysa::cuda
