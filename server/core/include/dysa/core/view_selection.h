// A view stream's subset on the host: the candidates' keys (dysa/view_key.h) and the budget's
// smallest, as the service's ViewOrder and the CPU's Simulation::ReadViewSubset choose them. A
// GPU backend chooses the same ids on the device (cuda/view_subset.cuh) from the same request.
//
// The request holds what the key needs besides the particles: the box the grid spans, the stride
// and the per-cell weights as a function of the grid and each cell's candidate count (the
// camera's part: the service's, computed on the host in both cases). Plain C++17, no spans: the
// CUDA sources include it.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include "dysa/view_key.h"

namespace dysa {

// Fills weights[c] (> 0) for every cell c of the kViewCells with counts[c] > 0 candidates; the
// other cells' entries are never read. Called once per selection, on the calling thread.
using ViewWeigher =
    std::function<void(const ViewGrid& grid, const uint32_t* counts, double* weights)>;

struct ViewSubsetRequest {
  // The box the grid spans (m); per degenerate axis the particles' bounds (MakeViewGrid).
  std::array<double, 3> box_min{}, box_max{};
  uint32_t stride = 1;  // candidates: the ids with id % stride == 0 (0 reads as 1)
  ViewWeigher weigh;
};

class ViewKeys {
 public:
  // `positions`: 3 per particle for n particles, in id order. Calls request.weigh once, also
  // without particles (every count then 0).
  ViewKeys(const float* positions, size_t n, const ViewSubsetRequest& request);

  uint32_t stride() const { return stride_; }
  // Candidates: ids with id % stride == 0.
  uint32_t candidates() const { return uint32_t(keys_.size()); }
  // The cell of candidate k (id k * stride).
  uint32_t cell_of(uint32_t k) const { return cell_of_[k]; }
  // The `budget` smallest keys' ids, increasing (every candidate when budget >= candidates()).
  // Ties go to the smaller id, so a larger budget only adds ids.
  std::vector<uint32_t> Select(uint64_t budget) const;

 private:
  uint32_t stride_;
  std::vector<float> keys_;        // per candidate k
  std::vector<uint32_t> cell_of_;  // per candidate k
};

}  // namespace dysa
