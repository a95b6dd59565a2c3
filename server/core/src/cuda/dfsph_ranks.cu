// The dfsph pipeline's part on one of several processes (dfsph_ranks.cuh).
#include <cuda_runtime.h>

#include <cstring>
#include <stdexcept>

#include "cuda/dfsph_ranks.cuh"
#include "cuda/sph_kernels.cuh"

namespace dysa::cuda {
namespace {

constexpr unsigned kRankBlock = 256;
unsigned Blocks(uint32_t count) { return (count + kRankBlock - 1) / kRankBlock; }

// xyz[k] = v[index[k]]: the velocities of the owned particles other processes read.
__global__ void PackVelocitiesKernel(const float* vx, const float* vy, const float* vz,
                                     const uint32_t* index, float* xyz, uint32_t count) {
  const uint32_t k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k >= count) return;
  const uint32_t i = index[k];
  xyz[3 * k] = vx[i], xyz[3 * k + 1] = vy[i], xyz[3 * k + 2] = vz[i];
}

// v[index[k]] = xyz[k]: the ghosts take their owners' velocities (each ghost once).
__global__ void UnpackVelocitiesKernel(const float* xyz, const uint32_t* index, float* vx,
                                       float* vy, float* vz, uint32_t count) {
  const uint32_t k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k >= count) return;
  const uint32_t i = index[k];
  vx[i] = xyz[3 * k], vy[i] = xyz[3 * k + 1], vz[i] = xyz[3 * k + 2];
}

// MaximaInputsKernel (sph_kernels.cuh) with the ghosts at 0, and the densities so masked.
__global__ void GhostMaskedMaximaKernel(const float* vx, const float* vy, const float* vz,
                                        const float* ax, const float* ay, const float* az,
                                        const float* density, const uint8_t* ghost, float* speed2,
                                        float* acceleration2, float* owned_density, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const bool owned = ghost[i] == 0;
  speed2[i] = owned ? sph::Norm2({vx[i], vy[i], vz[i]}) : 0.0f;
  acceleration2[i] = owned ? sph::Norm2({ax[i], ay[i], az[i]}) : 0.0f;
  owned_density[i] = owned ? density[i] : 0.0f;
}

}  // namespace

void* PinnedStaging::Buffer(size_t slot, size_t bytes) {
  if (slots_.size() <= slot) slots_.resize(slot + 1);
  if (!slots_[slot]) slots_[slot] = std::make_unique<PinnedBuffer<unsigned char>>();
  slots_[slot]->Resize(bytes);
  return slots_[slot]->data();
}

void PinnedStaging::Unstage() {
  for (const Pending& p : pending_) std::memcpy(p.out, p.staged, p.bytes);
  pending_.clear();
}

void PinnedStaging::Upload(ParticleBuffers& p, const uint32_t* id, const float* position,
                           const float* velocity, std::initializer_list<UpArray> own) {
  const size_t n = p.n;
  cudaStream_t s = p.stream.get();
  p.EnqueueUpload(Up(0, id, n), Up(1, position, 3 * n), Up(2, velocity, 3 * n));
  size_t slot = 3;
  for (const auto& [device, host] : own) {
    const float* from = Up(slot++, host, n);
    if (from && n > 0) {
      CheckCuda(cudaMemcpyAsync(device->data(), from, n * sizeof(float), cudaMemcpyHostToDevice, s),
                "uploading a solver's array");
    }
  }
  CheckCuda(cudaStreamSynchronize(s), "uploading particles");
}

void PinnedStaging::Download(const ParticleBuffers& p, uint32_t* id, float* position,
                             float* velocity, float* density, float* pressure,
                             std::initializer_list<DownArray> own) {
  const size_t n = p.n;
  cudaStream_t s = p.stream.get();
  p.EnqueueDownload(Down(0, id, n), Down(1, position, 3 * n), Down(2, velocity, 3 * n),
                    Down(3, density, n), Down(4, pressure, n));
  size_t slot = 5;
  for (const auto& [device, host] : own) {
    if (host) device->CopyTo(Down(slot, host, n), n, s);
    ++slot;
  }
  CheckCuda(cudaStreamSynchronize(s), "downloading particles");
  Unstage();
}

void PinnedStaging::DownloadSortedOrder(const ParticleBuffers& p, uint32_t* id, uint32_t* cells) {
  const size_t n = p.n;
  if (n == 0) return;
  cudaStream_t s = p.stream.get();
  if (id) p.id.CopyTo(Down(0, id, n), n, s);
  if (cells) {
    CheckCuda(cudaMemcpyAsync(Down(1, cells, n), p.sorter.View().sorted_key, n * sizeof(uint32_t),
                              cudaMemcpyDeviceToHost, s),
              "downloading the sorted cells");
  }
  CheckCuda(cudaStreamSynchronize(s), "downloading the sorted order");
  Unstage();
}

void DfsphRanks::Set(DfsphProcesses* link, const uint8_t* ghost_flags, uint32_t n,
                     const uint32_t* sent, size_t sent_total, const uint32_t* received,
                     size_t received_total, cudaStream_t s) {
  processes = link;
  owned = 0;
  sent_count = received_count = 0;
  if (!link) return;
  if (sent_total > UINT32_MAX / 3 || received_total > UINT32_MAX / 3) {
    throw std::length_error("too many ghosts to refresh on the GPU");
  }
  sent_count = uint32_t(sent_total);
  received_count = uint32_t(received_total);
  for (uint32_t k = 0; k < n; ++k) owned += ghost_flags[k] == 0 ? 1 : 0;
  ghost.Resize(n > 0 ? n : 1);
  sent_index.Resize(sent_count > 0 ? sent_count : 1);
  received_index.Resize(received_count > 0 ? received_count : 1);
  sent_values.Resize(3 * size_t(sent_count) + 1);
  received_values.Resize(3 * size_t(received_count) + 1);
  sent_host.Resize(3 * size_t(sent_count) + 1);
  received_host.Resize(3 * size_t(received_count) + 1);
  owned_density.Resize(n > 0 ? n : 1);
  auto up = [s](void* to, const void* from, size_t bytes) {
    if (bytes > 0) {
      CheckCuda(cudaMemcpyAsync(to, from, bytes, cudaMemcpyHostToDevice, s), "uploading a plan");
    }
  };
  up(ghost.data(), ghost_flags, n);
  up(sent_index.data(), sent, sent_count * sizeof(uint32_t));
  up(received_index.data(), received, received_count * sizeof(uint32_t));
  // The host's plan may be freed once this returns.
  CheckCuda(cudaStreamSynchronize(s), "uploading the ghost refresh's plan");
}

void DfsphRanks::RefreshVelocities(float* vx, float* vy, float* vz, cudaStream_t s) {
  if (!active()) return;
  if (sent_count > 0) {
    PackVelocitiesKernel<<<Blocks(sent_count), kRankBlock, 0, s>>>(vx, vy, vz, sent_index.data(),
                                                                   sent_values.data(), sent_count);
    CheckCuda(cudaGetLastError(), "launching the ghosts' packing");
    sent_host.CopyFrom(sent_values, 3 * size_t(sent_count), s);
  }
  CheckCuda(cudaStreamSynchronize(s), "reading back the velocities other processes read");
  processes->ExchangeVelocities(sent_host.data(), sent_count, received_host.data(), received_count);
  if (received_count > 0) {
    CheckCuda(
        cudaMemcpyAsync(received_values.data(), received_host.data(),
                        3 * size_t(received_count) * sizeof(float), cudaMemcpyHostToDevice, s),
        "uploading the ghosts' velocities");
    UnpackVelocitiesKernel<<<Blocks(received_count), kRankBlock, 0, s>>>(
        received_values.data(), received_index.data(), vx, vy, vz, received_count);
    CheckCuda(cudaGetLastError(), "launching the ghosts' unpacking");
  }
  // The next kernels on the stream read the ghosts' velocities; the page-locked buffer is
  // reused by the next refresh only after the stream has passed this copy (that refresh
  // synchronises before it writes it).
}

void DfsphRanks::OwnedMaximaInputs(const float* vx, const float* vy, const float* vz,
                                   const float* ax, const float* ay, const float* az,
                                   const float* density, float* speed2, float* acceleration2,
                                   uint32_t n, cudaStream_t s) {
  if (n == 0) return;
  GhostMaskedMaximaKernel<<<Blocks(n), kRankBlock, 0, s>>>(vx, vy, vz, ax, ay, az, density,
                                                           ghost.data(), speed2, acceleration2,
                                                           owned_density.data(), n);
  CheckCuda(cudaGetLastError(), "launching the owned particles' maxima");
}

}  // namespace dysa::cuda
