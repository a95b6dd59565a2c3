// The particle arrays every GPU pipeline keeps (seed, wcsph, dfsph) and their copies to and from
// the host, in one place: ids, positions, velocities, densities and pressures in the grid's
// order, the permutation targets the neighbour sort swaps them with, the grid sorter, and the
// read-outs (storage order here; particle-id order, a level of detail's subset, a view stream's
// subset, a list of ids, the position bounds and the probes' gather through ParticleReadout,
// particle_readout.h).
//
// A pipeline's Impl derives from it (the physical solvers' through PhysicalArrays) and adds the
// arrays only it has, so that its kernels' views and the templates over "a pipeline's state"
// (ProbeParticlesOf, SubsetParticlesOf) read the members by their plain names.
#pragma once

#include <cuda_runtime.h>

#include <cstddef>
#include <cstdint>
#include <initializer_list>

#include "cuda/device_buffer.cuh"
#include "cuda/device_grid.cuh"
#include "cuda/probe_gatherer.cuh"
#include "cuda/rank_subset.cuh"
#include "cuda/view_reads.cuh"
#include "cuda/view_subset.cuh"

namespace dysa::cuda {

struct ParticleBuffers {
  explicit ParticleBuffers(int device_index);

  // Grows the shared per-particle arrays and the pipeline's `own` to `elements` values each and
  // the sorter to sort `count` particles; n becomes count. Throws std::length_error for more
  // particles than the 32-bit indices can address.
  void AllocateParticles(size_t count, size_t elements,
                         std::initializer_list<DeviceBuffer<float>*> own);

  // Enqueues the copy of n ids and n xyz positions and velocities (storage order) and zeroes the
  // densities and pressures, which the step computes, so that a download before the first step
  // reads zeros as the CPU's fresh arrays do. The caller adds its own arrays, then waits.
  void EnqueueUpload(const uint32_t* host_id, const float* position, const float* velocity);

  // Enqueues the copies back in storage order; any pointer may be null (not copied). The caller
  // adds its own arrays, then waits.
  void EnqueueDownload(uint32_t* host_id, float* position, float* velocity, float* host_density,
                       float* host_pressure) const;

  // Bytes of the shared arrays, the sorter and the subsets' buffers.
  uint64_t ParticleDeviceBytes() const;

  // data becomes data permuted by `order` (out[k] = in[order[k]]); target holds the old values.
  template <class T>
  void Gather(const uint32_t* order, DeviceBuffer<T>& data, DeviceBuffer<T>& target,
              uint32_t count) {
    GatherByOrder(order, data.data(), target.data(), count, stream.get());
    data.swap(target);
  }

  int device;
  Stream stream;
  uint32_t n = 0;
  // Positions, velocities and their permutation targets (swapped after each sort).
  DeviceBuffer<float> x, y, z, vx, vy, vz, x2, y2, z2, vx2, vy2, vz2;
  DeviceBuffer<uint32_t> id, id2;
  DeviceBuffer<float> density, pressure;
  GridSorter sorter;
  // ParticleReadout's: DownloadById's staging, the probes' gather, DownloadBelowRank's subset,
  // DownloadViewSubset's, DownloadByIds' and DownloadPositionBounds'.
  DeviceBuffer<float> frame_staging;
  ProbeGatherer probe_gatherer;
  RankSubset rank_subset;
  ViewSubset view_subset;
  ViewReads view_reads;
};

}  // namespace dysa::cuda
