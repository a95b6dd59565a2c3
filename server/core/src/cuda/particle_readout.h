// What the host reads back from a GPU pipeline's particles whatever its solver (seed, wcsph,
// dfsph): their count, the positions, velocities and densities in particle-id order, a level of
// detail's subset, a view stream's subset, a list of ids' particles, the position bounds, the
// probes' gather and the neighbour sort's fullest cell. Each pipeline
// derives from it and points it at its particle arrays (ParticleBuffers, particle_buffers.cuh).
// A plain interface: the C++ compiler reads it without CUDA.
#pragma once

#include <cstddef>
#include <cstdint>

#include "dysa/core/view_selection.h"
#include "probe_gather.h"
#include "rank_subset.h"

namespace dysa::cuda {

struct ParticleBuffers;

class ParticleReadout {
 public:
  // Positions and velocities (xyz triples) and densities in particle-id order (id k at k);
  // any pointer may be null (not copied).
  void DownloadById(float* position, float* velocity, float* density) const;
  // The particles of BelowRank(id, threshold) (threshold > 0) in id order, chosen and packed on
  // the device (rank_subset.cuh): only they cross to the host.
  RankSubsetCopy DownloadBelowRank(uint32_t threshold, bool position, bool velocity,
                                   bool density) const;
  // A view stream's subset, chosen and packed on the device (view_subset.cuh).
  RankSubsetCopy DownloadViewSubset(const ViewSubsetRequest& request, uint64_t budget,
                                    bool position, bool velocity, bool density) const;
  // The particles `ids` (count of them, each below size(), in any order), their asked fields
  // packed in the list's order and gathered on the device (view_reads.cuh): only they cross.
  RankSubsetCopy DownloadByIds(const uint32_t* ids, size_t count, bool position, bool velocity,
                               bool density) const;
  // Per axis the smallest (lo[a]) and largest (hi[a]) position, reduced on the device
  // (view_reads.cuh): NaN skipped, a zero extreme signed as the first zero in storage order;
  // lo +inf and hi -inf without particles.
  void DownloadPositionBounds(float* lo, float* hi) const;
  size_t size() const;
  // The most particles one grid cell held at the latest step's neighbour sort (read after the
  // step, or for dfsph after Prepare).
  uint32_t max_cell_count() const;

  // The probes' gather (probe_gather.h) over the particles, on the device.
  void GatherProbes(const ProbeGatherPlan& plan, ProbeGather& out) const;

 protected:
  ParticleReadout() = default;
  ~ParticleReadout() = default;
  ParticleReadout(const ParticleReadout&) = delete;
  ParticleReadout& operator=(const ParticleReadout&) = delete;

  // The pipeline's arrays (its Impl's), set by its constructor; they live as long as it does.
  ParticleBuffers* arrays_ = nullptr;
};

}  // namespace dysa::cuda
