// A view stream's reads between two selections on the GPU (view_reads.cuh): a gather by id and
// the position bounds.
#include <cuda_runtime.h>

#include <algorithm>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "cuda/ordered_float.cuh"
#include "cuda/view_reads.cuh"

namespace dysa::cuda {
namespace {

constexpr uint32_t kNoZero = 0xffffffffu;  // no zero seen (2 i + sign is below it)

__device__ uint32_t WarpMin(uint32_t v) {
  for (int offset = 16; offset > 0; offset /= 2) {
    v = min(v, __shfl_xor_sync(0xffffffffu, v, offset));
  }
  return v;
}
__device__ uint32_t WarpMax(uint32_t v) {
  for (int offset = 16; offset > 0; offset /= 2) {
    v = max(v, __shfl_xor_sync(0xffffffffu, v, offset));
  }
  return v;
}

// bounds[a] = min, bounds[3 + a] = max of the particles' non-NaN coordinates on axis a (as
// Ordered; NaN skipped as the host's std::min / std::max skip it), bounds[6 + a] = 2 i + sign
// of the first zero coordinate on axis a in storage order (i < 2^31: ParticleBuffers'
// limit). A grid-stride loop (every thread of a warp reaches the warp's reduction), one atomic
// per warp and word.
__global__ void BoundsKernel(SubsetParticles p, uint32_t* bounds) {
  uint32_t lo[3] = {kOrderedPlusInf, kOrderedPlusInf, kOrderedPlusInf};
  uint32_t hi[3] = {kOrderedMinusInf, kOrderedMinusInf, kOrderedMinusInf};
  uint32_t zero[3] = {kNoZero, kNoZero, kNoZero};
  const float* axis[3] = {p.x, p.y, p.z};
  const uint32_t step = gridDim.x * blockDim.x;
  for (uint32_t i = blockIdx.x * blockDim.x + threadIdx.x; i < p.n; i += step) {
    for (int a = 0; a < 3; ++a) {
      const float v = axis[a][i];
      if (v != v) continue;  // NaN
      const uint32_t bits = __float_as_uint(v);
      const uint32_t o = Ordered(bits);
      lo[a] = min(lo[a], o);
      hi[a] = max(hi[a], o);
      // This thread's i increase: its first zero is its earliest.
      if (v == 0.0f && zero[a] == kNoZero) zero[a] = (i << 1) | (bits >> 31);
    }
  }
  for (int a = 0; a < 3; ++a) {
    lo[a] = WarpMin(lo[a]);
    hi[a] = WarpMax(hi[a]);
    zero[a] = WarpMin(zero[a]);
  }
  if (threadIdx.x % 32 != 0) return;
  for (int a = 0; a < 3; ++a) {
    if (lo[a] != kOrderedPlusInf) atomicMin(&bounds[a], lo[a]);
    if (hi[a] != kOrderedMinusInf) atomicMax(&bounds[3 + a], hi[a]);
    if (zero[a] != kNoZero) atomicMin(&bounds[6 + a], zero[a]);
  }
}

// index_of[id[i]] = i: the storage index of every id.
__global__ void IndexKernel(const uint32_t* id, uint32_t n, uint32_t* index_of) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) index_of[id[i]] = i;
}

// Entry j of each asked output: particle ids[j]'s values. Null outputs are not written.
__global__ void PackByIdKernel(SubsetParticles p, const uint32_t* ids, uint32_t count,
                               const uint32_t* index_of, float* position, float* velocity,
                               float* density) {
  const uint32_t j = blockIdx.x * blockDim.x + threadIdx.x;
  if (j >= count) return;
  const uint32_t i = index_of[ids[j]];
  const size_t k = j;
  if (position) {
    position[3 * k] = p.x[i];
    position[3 * k + 1] = p.y[i];
    position[3 * k + 2] = p.z[i];
  }
  if (velocity) {
    velocity[3 * k] = p.vx[i];
    velocity[3 * k + 1] = p.vy[i];
    velocity[3 * k + 2] = p.vz[i];
  }
  if (density) density[k] = p.density[i];
}

unsigned Blocks(uint64_t n) { return unsigned((n + kBlock - 1) / kBlock); }

}  // namespace

RankSubsetCopy ViewReads::DownloadByIds(const SubsetParticles& p, const uint32_t* ids, size_t count,
                                        bool position, bool velocity, bool density,
                                        cudaStream_t stream) {
  RankSubsetCopy copy;
  copy.count = count;
  copy.ids = ids;
  const size_t c = count;
  // One buffer: [positions 3c][velocities 3c][densities c], the parts asked for.
  const size_t position_at = 0;
  const size_t velocity_at = position_at + (position ? 3 * c : 0);
  const size_t density_at = velocity_at + (velocity ? 3 * c : 0);
  const size_t floats = density_at + (density ? c : 0);
  if (floats == 0) return copy;
  if (count > uint64_t(UINT32_MAX) / 2) throw std::length_error("too many ids for the GPU");
  // The list to the device.
  host_ids_.Resize(c);
  std::memcpy(host_ids_.data(), ids, c * sizeof(uint32_t));
  ids_.Resize(c);
  CheckCuda(cudaMemcpyAsync(ids_.data(), host_ids_.data(), c * sizeof(uint32_t),
                            cudaMemcpyHostToDevice, stream),
            "uploading a view's ids");
  // Where each id lies now.
  index_of_.Resize(std::max<size_t>(p.n, 1));
  IndexKernel<<<Blocks(p.n), kBlock, 0, stream>>>(p.id, p.n, index_of_.data());
  // The listed particles' values, packed in the list's order, to the host.
  packed_.Resize(floats);
  host_packed_.Resize(floats);
  float* out = packed_.data();
  PackByIdKernel<<<Blocks(c), kBlock, 0, stream>>>(
      p, ids_.data(), uint32_t(c), index_of_.data(), position ? out + position_at : nullptr,
      velocity ? out + velocity_at : nullptr, density ? out + density_at : nullptr);
  host_packed_.CopyFrom(packed_, floats, stream);
  CheckCuda(cudaStreamSynchronize(stream), "downloading a view's particles by id");
  const float* host = host_packed_.data();
  if (position) copy.position = host + position_at;
  if (velocity) copy.velocity = host + velocity_at;
  if (density) copy.density = host + density_at;
  return copy;
}

void ViewReads::DownloadPositionBounds(const SubsetParticles& p, float* lo, float* hi,
                                       cudaStream_t stream) {
  for (int a = 0; a < 3; ++a) {
    lo[a] = std::numeric_limits<float>::infinity();
    hi[a] = -std::numeric_limits<float>::infinity();
  }
  if (p.n == 0) return;
  bounds_.Resize(9);
  host_bounds_.Resize(9);
  uint32_t* host = host_bounds_.data();
  for (int a = 0; a < 3; ++a) {
    host[a] = kOrderedPlusInf, host[3 + a] = kOrderedMinusInf, host[6 + a] = kNoZero;
  }
  CheckCuda(
      cudaMemcpyAsync(bounds_.data(), host, 9 * sizeof(uint32_t), cudaMemcpyHostToDevice, stream),
      "uploading a view's bounds");
  BoundsKernel<<<std::min(Blocks(p.n), 1024u), kBlock, 0, stream>>>(p, bounds_.data());
  host_bounds_.CopyFrom(bounds_, 9, stream);
  CheckCuda(cudaStreamSynchronize(stream), "bounding the particles");
  for (int a = 0; a < 3; ++a) {
    lo[a] = FromOrdered(host[a]);
    hi[a] = FromOrdered(host[3 + a]);
    // A zero extreme: the host keeps the first zero it meets (std::min and std::max keep the
    // first of equal values), so its sign is the first zero's in storage order.
    const float first_zero = (host[6 + a] & 1u) ? -0.0f : 0.0f;
    if (lo[a] == 0) lo[a] = first_zero;
    if (hi[a] == 0) hi[a] = first_zero;
  }
}

uint64_t ViewReads::DeviceBytes() const {
  return uint64_t(ids_.capacity() + index_of_.capacity() + bounds_.capacity()) * sizeof(uint32_t) +
         uint64_t(packed_.capacity()) * sizeof(float);
}

}  // namespace dysa::cuda
