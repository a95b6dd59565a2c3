// The pipelines' shared particle arrays (particle_buffers.cuh) and their read-outs
// (particle_readout.h).
#include <cuda_runtime.h>

#include <stdexcept>

#include "cuda/particle_buffers.cuh"
#include "cuda/particle_readout.h"

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

void ParticleReadout::DownloadById(float* position, float* velocity, float* density) const {
  const ParticleBuffers& a = *arrays_;
  DeviceScope scope(a.device);
  cudaStream_t s = a.stream.get();
  const uint32_t* id = a.id.data();
  DeviceBuffer<float>& staging = arrays_->frame_staging;
  if (position) {
    cuda::DownloadById(id, a.x.data(), a.y.data(), a.z.data(), a.n, position, staging, s);
  }
  if (velocity) {
    cuda::DownloadById(id, a.vx.data(), a.vy.data(), a.vz.data(), a.n, velocity, staging, s);
  }
  if (density) {
    cuda::DownloadById(id, a.density.data(), nullptr, nullptr, a.n, density, staging, s);
  }
}

RankSubsetCopy ParticleReadout::DownloadBelowRank(uint32_t threshold, bool position, bool velocity,
                                                  bool density) const {
  DeviceScope scope(arrays_->device);
  return arrays_->rank_subset.Download(SubsetParticlesOf(*arrays_), threshold, position, velocity,
                                       density, arrays_->stream.get());
}

RankSubsetCopy ParticleReadout::DownloadViewSubset(const ViewSubsetRequest& request,
                                                   uint64_t budget, bool position, bool velocity,
                                                   bool density) const {
  DeviceScope scope(arrays_->device);
  return arrays_->view_subset.Download(SubsetParticlesOf(*arrays_), request, budget, position,
                                       velocity, density, arrays_->stream.get());
}

RankSubsetCopy ParticleReadout::DownloadByIds(const uint32_t* ids, size_t count, bool position,
                                              bool velocity, bool density) const {
  DeviceScope scope(arrays_->device);
  return arrays_->view_reads.DownloadByIds(SubsetParticlesOf(*arrays_), ids, count, position,
                                           velocity, density, arrays_->stream.get());
}

void ParticleReadout::DownloadPositionBounds(float* lo, float* hi) const {
  DeviceScope scope(arrays_->device);
  arrays_->view_reads.DownloadPositionBounds(SubsetParticlesOf(*arrays_), lo, hi,
                                             arrays_->stream.get());
}

size_t ParticleReadout::size() const { return arrays_->n; }

uint32_t ParticleReadout::max_cell_count() const { return arrays_->sorter.max_count(); }

void ParticleReadout::GatherProbes(const ProbeGatherPlan& plan, ProbeGather& out) const {
  DeviceScope scope(arrays_->device);
  arrays_->probe_gatherer.Gather(ProbeParticlesOf(*arrays_), plan, arrays_->stream.get(), out);
}

uint64_t ParticleBuffers::ParticleDeviceBytes() const {
  // 14 float arrays (positions, velocities, their permutation targets, densities, pressures)
  // and the two id arrays.
  return uint64_t(x.capacity()) * (14 * sizeof(float) + 2 * sizeof(uint32_t)) +
         sorter.DeviceBytes() + rank_subset.DeviceBytes() + view_subset.DeviceBytes() +
         view_reads.DeviceBytes();
}

}  // namespace dysa::cuda
