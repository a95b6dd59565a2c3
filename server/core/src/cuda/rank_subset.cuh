// A level of detail's subset chosen on the GPU (rank_subset.h): the particles of
// BelowRank(id, threshold) are packed in id order into one device buffer by one kernel and
// cross to the host in one copy, so a frame of a budgeted stream moves only the particles it
// sends. Shared by the three pipelines, as the probe gatherer.
#pragma once

#include <cstdint>
#include <vector>

#include "cuda/device_buffer.cuh"
#include "rank_subset.h"

namespace dysa::cuda {

// A pipeline's particle arrays in storage order (device pointers): n ids (a permutation of
// 0 .. n - 1), positions, velocities and densities.
struct SubsetParticles {
  uint32_t n = 0;
  const uint32_t* id = nullptr;
  const float *x = nullptr, *y = nullptr, *z = nullptr;
  const float *vx = nullptr, *vy = nullptr, *vz = nullptr;
  const float* density = nullptr;  // kg/m^3
};

// The SubsetParticles of a pipeline's state (any struct with device buffers n, id, x, y, z, vx,
// vy, vz and density: the pipelines' ParticleBuffers, particle_buffers.cuh).
template <class Arrays>
SubsetParticles SubsetParticlesOf(const Arrays& a) {
  SubsetParticles p;
  p.n = uint32_t(a.n);
  p.id = a.id.data();
  p.x = a.x.data(), p.y = a.y.data(), p.z = a.z.data();
  p.vx = a.vx.data(), p.vy = a.vy.data(), p.vz = a.vz.data();
  p.density = a.density.data();
  return p;
}

class RankSubset {
 public:
  // The particles of BelowRank(id, threshold) (threshold > 0): their ids and the asked arrays,
  // in id order, in this object's host memory until the next call. The kept ids (a table built
  // on the device, and its host copy) are cached for the latest particle count and threshold;
  // each call then runs one kernel over the particles and one copy of the kept ones' values.
  // Runs on `stream` and waits for it.
  RankSubsetCopy Download(const SubsetParticles& particles, uint32_t threshold, bool position,
                          bool velocity, bool density, cudaStream_t stream);
  // Device memory held, bytes.
  uint64_t DeviceBytes() const;

 private:
  // The ids below n of BelowRank(id, threshold), increasing, into kept_ and host_kept_.
  void BuildTable(uint32_t n, uint32_t threshold, cudaStream_t stream);

  bool cached_ = false;  // kept_ holds the table of (table_n_, table_threshold_)
  uint32_t table_n_ = 0;
  uint32_t table_threshold_ = 0;
  DeviceBuffer<uint32_t> kept_;
  std::vector<uint32_t> host_kept_;
  DeviceBuffer<uint32_t> count_;  // the kept particles, counted
  PinnedBuffer<uint32_t> host_count_;
  DeviceBuffer<unsigned char> temp_;  // CUB's scratch
  DeviceBuffer<float> packed_;        // positions, velocities, densities of the kept particles
  PinnedBuffer<float> host_packed_;
};

}  // namespace dysa::cuda
