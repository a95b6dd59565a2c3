// The reads a view stream's frames make between two selections, on the GPU
// (Simulation::ReadParticlesByIds, ReadPositionBounds; docs/server.md, "What a watched frame
// reads"): the particles of a list of ids, gathered where they live, and every particle's
// position extremes, reduced where they live. Shared by the three pipelines, as RankSubset and
// ViewSubset.
//
// A gather by id, for n particles and a list of c ids (any order):
// 1. the list to the device (4 bytes an id, through pinned memory);
// 2. the storage index of every id (the inverse of the storage's id permutation; one kernel over
//    the particles, which move every step, so it is rebuilt at each call);
// 3. the asked fields of the listed particles packed in the list's order (one kernel over the
//    list), and the packed bytes to the host (12 bytes per vector, 4 per density, per id).
// The bounds: one kernel over the particles reduces per axis the smallest and largest non-NaN
// coordinate (ordered integer encodings, integer atomics: any order, same result) and the first
// zero in storage order (which decides the sign of a zero extreme, as the host's std::min and
// std::max keep the first of equal values); 9 words come back.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "cuda/device_buffer.cuh"
#include "cuda/rank_subset.cuh"
#include "rank_subset.h"

namespace dysa::cuda {

class ViewReads {
 public:
  // The particles `ids` (count of them, each below particles.n, in any order): the asked arrays
  // packed in the list's order (entry j is ids[j]'s), in this object's host memory until the
  // next call; the copy's ids are `ids`. Runs on `stream` and waits for it.
  RankSubsetCopy DownloadByIds(const SubsetParticles& particles, const uint32_t* ids, size_t count,
                               bool position, bool velocity, bool density, cudaStream_t stream);
  // Per axis the smallest (lo) and largest (hi) position of every particle, NaN skipped, a zero
  // extreme signed as the first zero in storage order (the host's sequential std::min and
  // std::max over the storage); lo +inf and hi -inf where an axis has no number. Runs on
  // `stream` and waits for it.
  void DownloadPositionBounds(const SubsetParticles& particles, float* lo, float* hi,
                              cudaStream_t stream);
  // Device memory held, bytes.
  uint64_t DeviceBytes() const;

 private:
  PinnedBuffer<uint32_t> host_ids_;  // the list, staged for the upload
  DeviceBuffer<uint32_t> ids_;
  DeviceBuffer<uint32_t> index_of_;  // per id: its storage index
  DeviceBuffer<float> packed_;       // positions, velocities, densities of the listed particles
  PinnedBuffer<float> host_packed_;
  DeviceBuffer<uint32_t> bounds_;  // ordered min x, y, z, max x, y, z; first zero x, y, z
  PinnedBuffer<uint32_t> host_bounds_;
};

}  // namespace dysa::cuda
