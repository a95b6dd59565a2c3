// What the dfsph pipeline (dfsph_pipeline.cu) adds on one of several processes, each stepping
// its slab's owned particles and ghosts on its GPU (server/distributed's device step): the ghost
// flags that keep the ghosts out of the reductions that steer the step, the refresh of the
// ghosts' velocities through page-locked host buffers, and the pinned staging of the particles'
// copies to and from the host each step.
//
// The refresh. After every update of the velocities (each iteration of both solves, their warm
// starts, predict_velocity) the CPU path gives every ghost its owner's velocity
// (ProcessShare::refresh_ghosts). Here the owned particles that other processes read (the plan's
// `sent`, a few layers of the slab) are packed on the device into one xyz array, copied to a
// page-locked buffer, handed to the host's exchange (DfsphProcesses::ExchangeVelocities), and
// what comes back is copied up and scattered into the ghosts (`received`): 12 bytes a particle
// each way for those only, not the whole share.
#pragma once

#include <cuda_runtime.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <initializer_list>
#include <memory>
#include <utility>
#include <vector>

#include "cuda/device_buffer.cuh"
#include "cuda/dfsph_pipeline.h"
#include "cuda/particle_buffers.cuh"

namespace dysa::cuda {

// Page-locked copies of the host arrays a step's upload reads and its download writes
// (DfsphPipeline::UsePinnedStaging): a copy from pageable memory goes through the driver's own
// staging, one from page-locked memory is a DMA. Off: the host arrays are used directly.
class PinnedStaging {
 public:
  bool on = false;
  // Where an upload of `count` values from `values` reads: `values` itself, or a page-locked
  // copy of them in buffer `slot`.
  template <class T>
  const T* Up(size_t slot, const T* values, size_t count) {
    if (!on || !values || count == 0) return values;
    void* copy = Buffer(slot, count * sizeof(T));
    std::memcpy(copy, values, count * sizeof(T));
    return static_cast<const T*>(copy);
  }
  // Where a download of `count` values into `out` writes: `out` itself, or buffer `slot`, from
  // which Unstage copies them into `out` once the stream has passed the copy.
  template <class T>
  T* Down(size_t slot, T* out, size_t count) {
    if (!on || !out || count == 0) return out;
    void* copy = Buffer(slot, count * sizeof(T));
    pending_.push_back({out, copy, count * sizeof(T)});
    return static_cast<T*>(copy);
  }
  // After the stream has synchronised: the downloads' bytes where their callers wanted them.
  void Unstage();

  // A pipeline's own per-particle arrays beside the shared ones, with the host's values (n each;
  // a null host pointer is not copied).
  using UpArray = std::pair<DeviceBuffer<float>*, const float*>;
  using DownArray = std::pair<const DeviceBuffer<float>*, float*>;
  // ParticleBuffers::EnqueueUpload of p.n particles and `own`, through the staging; waits.
  void Upload(ParticleBuffers& p, const uint32_t* id, const float* position, const float* velocity,
              std::initializer_list<UpArray> own);
  // ParticleBuffers::EnqueueDownload and `own`, through the staging; waits.
  void Download(const ParticleBuffers& p, uint32_t* id, float* position, float* velocity,
                float* density, float* pressure, std::initializer_list<DownArray> own);
  // Each particle's id and the cell of the latest sort (its sorter's keys), storage order.
  void DownloadSortedOrder(const ParticleBuffers& p, uint32_t* id, uint32_t* cells);

 private:
  void* Buffer(size_t slot, size_t bytes);

  struct Pending {
    void* out;
    const void* staged;
    size_t bytes;
  };
  std::vector<std::unique_ptr<PinnedBuffer<unsigned char>>> slots_;
  std::vector<Pending> pending_;
};

struct DfsphRanks {
  // Null: one process (no ghosts, nothing to exchange).
  DfsphProcesses* processes = nullptr;
  int64_t owned = 0;  // particles held here that are not ghosts
  uint32_t sent_count = 0, received_count = 0;
  DeviceBuffer<uint8_t> ghost;  // per particle, storage order: 0 owned
  DeviceBuffer<uint32_t> sent_index, received_index;
  DeviceBuffer<float> sent_values, received_values;  // xyz triples
  PinnedBuffer<float> sent_host, received_host;
  DeviceBuffer<float> owned_density;  // the densities the time step's maximum reads

  bool active() const { return processes != nullptr; }
  // The skip flags of the reductions over the owned particles; null on one process.
  const uint8_t* GhostFlags() const { return active() ? ghost.data() : nullptr; }
  uint64_t DeviceBytes() const {
    return ghost.capacity() + (sent_index.capacity() + received_index.capacity()) * 4 +
           (sent_values.capacity() + received_values.capacity() + owned_density.capacity()) * 4;
  }

  // DfsphPipeline::SetProcesses's plan, uploaded for the step (n particles held).
  void Set(DfsphProcesses* link, const uint8_t* ghost_flags, uint32_t n, const uint32_t* sent,
           size_t sent_total, const uint32_t* received, size_t received_total, cudaStream_t s);
  // Every ghost's velocity becomes its owner's (collective; nothing on one process).
  void RefreshVelocities(float* vx, float* vy, float* vz, cudaStream_t s);
  // The time step's maxima inputs with the ghosts at 0 (no maximum is below it: the CPU's start):
  // |v|^2, |a|^2 and the density into `owned_density`.
  void OwnedMaximaInputs(const float* vx, const float* vy, const float* vz, const float* ax,
                         const float* ay, const float* az, const float* density, float* speed2,
                         float* acceleration2, uint32_t n, cudaStream_t s);
};

}  // namespace dysa::cuda
