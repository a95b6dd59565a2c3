// The probes' gather (probe_gather.h) on the GPU: one kernel reads every particle once, reduces
// what the global probes need into per-block partial sums and appends the particles inside each
// local probe's window to a buffer; only those cross to the host.
#pragma once

#include <cstdint>
#include <vector>

#include "cuda/device_buffer.cuh"
#include "probe_gather.h"

namespace dysa::cuda {

// A pipeline's particle arrays in storage order (device pointers); velocity, density and
// pressure may be null when the plan does not read them.
struct ProbeParticles {
  uint32_t n = 0;
  const float *x = nullptr, *y = nullptr, *z = nullptr;
  const float *vx = nullptr, *vy = nullptr, *vz = nullptr;
  const float* density = nullptr;   // kg/m^3
  const float* pressure = nullptr;  // Pa
};

// The ProbeParticles of a pipeline's state (any struct with device buffers n, x, y, z, vx, vy,
// vz, density and pressure: the pipelines' ParticleBuffers, particle_buffers.cuh).
template <class Arrays>
ProbeParticles ProbeParticlesOf(const Arrays& a) {
  ProbeParticles p;
  p.n = a.n;
  p.x = a.x.data(), p.y = a.y.data(), p.z = a.z.data();
  p.vx = a.vx.data(), p.vy = a.vy.data(), p.vz = a.vz.data();
  p.density = a.density.data();
  p.pressure = a.pressure.data();
  return p;
}

// A particle inside a local probe's window, and which window (the gather appends every window's
// particles to one buffer).
struct WindowHit {
  uint32_t window;
  ProbeCandidate candidate;
};

class ProbeGatherer {
 public:
  // Runs on `stream` and waits for it. The partial sums are added on the host in block order,
  // and a block's particles depend only on n: the same particles give the same values.
  void Gather(const ProbeParticles& particles, const ProbeGatherPlan& plan, cudaStream_t stream,
              ProbeGather& out);

 private:
  DeviceBuffer<ProbeWindow> windows_;
  DeviceBuffer<ProbeBox> boxes_;
  std::vector<ProbeWindow> windows_uploaded_;  // what windows_ and boxes_ hold
  std::vector<ProbeBox> boxes_uploaded_;
  DeviceBuffer<double> partials_;  // per block: the values of ReductionSlots
  DeviceBuffer<uint32_t> hits_;    // the particles found in every window (may exceed capacity_)
  DeviceBuffer<WindowHit> found_;  // `capacity_` slots
  PinnedBuffer<double> host_partials_;
  PinnedBuffer<uint32_t> host_hits_;
  PinnedBuffer<WindowHit> host_found_;
  uint32_t capacity_ = 16384;  // hits over all windows; grows when they find more
  uint32_t last_hits_ = 0;     // what the last gather with windows found
};

}  // namespace dysa::cuda
