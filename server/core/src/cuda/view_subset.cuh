// A view stream's subset chosen on the GPU (dysa/core/view_selection.h): the same ids as the
// host's ViewKeys, chosen where the particles live, so that only the chosen particles (and the
// grid's per-cell counts and weights) cross between host and device. Shared by the three
// pipelines, as RankSubset.
//
// One selection, for n particles, m = ceil(n / stride) candidates and a budget B < m:
// 1. the grid (dysa/view_key.h): the request's box; per degenerate axis the particles' bounds,
//    reduced on the device (6 floats come back);
// 2. each candidate's cell, by candidate index k = id / stride, and each cell's count (integer
//    atomics: any order, same counts); the counts come back (kViewCells * 4 bytes = 128 KiB);
// 3. the weights per cell on the host (the request's weigher: the camera's maths, the service's
//    own code) go back up (kViewCells * 8 bytes = 256 KiB);
// 4. each candidate's key ViewKey(k * stride, w(cell)) — the host's bits: one definition;
// 5. a stable radix sort of (key, k) pairs by key: ties stay in k order, so the first B pairs
//    are the B smallest keys under the host's order (key, then k);
// 6. the first B candidates flagged, and compacted into increasing k (CUB DeviceSelect);
// 7. the chosen particles' asked fields packed in id order, by one kernel over the particles
//    (a chosen one finds its slot by binary search in the increasing list).
// The chosen ids (4 bytes each) and the packed fields (12 bytes per vector, 4 per density) come
// back in one synchronisation. With B >= m every candidate is chosen: no grid, no sort.
#pragma once

#include <cstdint>
#include <vector>

#include "cuda/device_buffer.cuh"
#include "cuda/rank_subset.cuh"
#include "dysa/core/view_selection.h"
#include "rank_subset.h"

namespace dysa::cuda {

class ViewSubset {
 public:
  // The `budget` smallest keys' particles of the request, ids increasing (ViewKeys::Select's):
  // their ids and the asked arrays, in this object's host memory until the next call. Calls
  // request.weigh once when budget < candidates (not otherwise). Runs on `stream` and waits for
  // it.
  RankSubsetCopy Download(const SubsetParticles& particles, const ViewSubsetRequest& request,
                          uint64_t budget, bool position, bool velocity, bool density,
                          cudaStream_t stream);
  // Device memory held, bytes.
  uint64_t DeviceBytes() const;

 private:
  // Steps 1-6 (0 < budget < m): the budget's candidates flagged in flags_ and listed, k
  // increasing, in chosen_ (device), queued on `stream`.
  void Choose(const SubsetParticles& p, const ViewSubsetRequest& request, uint32_t stride,
              uint32_t m, uint32_t budget, cudaStream_t stream);
  // Step 1.
  ViewGrid Grid(const SubsetParticles& p, const ViewSubsetRequest& request, cudaStream_t stream);

  DeviceBuffer<uint32_t> bounds_;  // ordered encodings of min x, y, z, max x, y, z
  PinnedBuffer<uint32_t> host_bounds_;
  DeviceBuffer<uint32_t> cell_of_;  // per candidate
  DeviceBuffer<uint32_t> counts_;   // per cell
  PinnedBuffer<uint32_t> host_counts_;
  DeviceBuffer<double> weights_;  // per cell
  PinnedBuffer<double> host_weights_;
  DeviceBuffer<float> keys_, sorted_keys_;                 // per candidate
  DeviceBuffer<uint32_t> candidates_, sorted_candidates_;  // per candidate
  DeviceBuffer<unsigned char> flags_;                      // per candidate: chosen
  DeviceBuffer<uint32_t> chosen_;                          // the chosen k, increasing
  DeviceBuffer<int64_t> chosen_count_;
  DeviceBuffer<unsigned char> temp_;  // CUB's scratch
  PinnedBuffer<uint32_t> host_chosen_;
  std::vector<uint32_t> host_ids_;
  DeviceBuffer<float> packed_;  // positions, velocities, densities of the chosen particles
  PinnedBuffer<float> host_packed_;
};

}  // namespace dysa::cuda
