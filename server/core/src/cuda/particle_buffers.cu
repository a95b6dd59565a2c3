// The pipelines' shared particle arrays (particle_buffers.cuh).
#include <cuda_runtime.h>

#include <stdexcept>

#include "cuda/particle_buffers.cuh"

namespace dysa::cuda {

ParticleBuffers::ParticleBuffers(int device_index) : device(device_index), stream(device_index) {}

void ParticleBuffers::AllocateParticles(size_t count, size_t elements,
                                        std::initializer_list<DeviceBuffer<float>*> own) {
  if (count > uint64_t(UINT32_MAX) / 2) throw std::length_error("too many particles for the GPU");
  for (DeviceBuffer<float>* b :
       {&x, &y, &z, &vx, &vy, &vz, &x2, &y2, &z2, &vx2, &vy2, &vz2, &density, &pressure}) {
    b->Resize(elements);
  }
  for (DeviceBuffer<float>* b : own) b->Resize(elements);
  id.Resize(elements);
  id2.Resize(elements);
  sorter.Reserve(uint32_t(count));
  n = uint32_t(count);
}

void ParticleBuffers::EnqueueUpload(const uint32_t* host_id, const float* position,
                                    const float* velocity) {
  cudaStream_t s = stream.get();
  UploadInterleaved(position, n, x, y, z, s);
  UploadInterleaved(velocity, n, vx, vy, vz, s);
  if (n > 0) {
    CheckCuda(cudaMemcpyAsync(id.data(), host_id, size_t(n) * sizeof(uint32_t),
                              cudaMemcpyHostToDevice, s),
              "uploading ids");
  }
  density.Zero(s), pressure.Zero(s);
}

void ParticleBuffers::EnqueueDownload(uint32_t* host_id, float* position, float* velocity,
                                      float* host_density, float* host_pressure) const {
  cudaStream_t s = stream.get();
  if (host_id) id.CopyTo(host_id, n, s);
  if (position) DownloadInterleaved(x, y, z, n, position, s);
  if (velocity) DownloadInterleaved(vx, vy, vz, n, velocity, s);
  if (host_density) density.CopyTo(host_density, n, s);
  if (host_pressure) pressure.CopyTo(host_pressure, n, s);
}

void ParticleBuffers::DownloadById(float* position, float* velocity, float* host_density) const {
  DeviceScope scope(device);
  cudaStream_t s = stream.get();
  if (position)
    cuda::DownloadById(id.data(), x.data(), y.data(), z.data(), n, position, frame_staging, s);
  if (velocity)
    cuda::DownloadById(id.data(), vx.data(), vy.data(), vz.data(), n, velocity, frame_staging, s);
  if (host_density)
    cuda::DownloadById(id.data(), density.data(), nullptr, nullptr, n, host_density, frame_staging,
                       s);
}

RankSubsetCopy ParticleBuffers::DownloadBelowRank(uint32_t threshold, bool position, bool velocity,
                                                  bool with_density) const {
  DeviceScope scope(device);
  return rank_subset.Download(SubsetParticlesOf(*this), threshold, position, velocity, with_density,
                              stream.get());
}

void ParticleBuffers::GatherProbes(const ProbeGatherPlan& plan, ProbeGather& out) const {
  DeviceScope scope(device);
  probe_gatherer.Gather(ProbeParticlesOf(*this), plan, stream.get(), out);
}

uint64_t ParticleBuffers::ParticleDeviceBytes() const {
  // 14 float arrays (positions, velocities, their permutation targets, densities, pressures)
  // and the two id arrays.
  return uint64_t(x.capacity()) * (14 * sizeof(float) + 2 * sizeof(uint32_t)) +
         sorter.DeviceBytes() + rank_subset.DeviceBytes();
}

}  // namespace dysa::cuda
