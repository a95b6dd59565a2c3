#include "dysa/core/view_selection.h"

#include <algorithm>
#include <limits>

namespace dysa {

ViewKeys::ViewKeys(const float* positions, size_t n, const ViewSubsetRequest& request)
    : stride_(std::max<uint32_t>(1, request.stride)) {
  const size_t m = (n + stride_ - 1) / stride_;
  // The particles' bounds, on the axes where the box is degenerate (std::min and std::max skip
  // NaN coordinates: a comparison with NaN is false).
  double particle_min[3], particle_max[3];
  for (int a = 0; a < 3; ++a) {
    particle_min[a] = std::numeric_limits<double>::infinity();
    particle_max[a] = -particle_min[a];
    if (request.box_max[a] > request.box_min[a]) continue;
    for (size_t i = 0; i < n; ++i) {
      particle_min[a] = std::min(particle_min[a], double(positions[3 * i + a]));
      particle_max[a] = std::max(particle_max[a], double(positions[3 * i + a]));
    }
  }
  const ViewGrid grid =
      MakeViewGrid(request.box_min.data(), request.box_max.data(), particle_min, particle_max, n);
  cell_of_.resize(m);
  std::vector<uint32_t> count(kViewCells, 0);
  for (size_t k = 0; k < m; ++k) {
    const float* p = &positions[3 * k * stride_];
    cell_of_[k] = ViewCellOf(grid, p[0], p[1], p[2]);
    ++count[cell_of_[k]];
  }
  std::vector<double> weight(kViewCells, 0);
  request.weigh(grid, count.data(), weight.data());
  keys_.resize(m);
  for (size_t k = 0; k < m; ++k) keys_[k] = ViewKey(uint32_t(k * stride_), weight[cell_of_[k]]);
}

std::vector<uint32_t> ViewKeys::Select(uint64_t budget) const {
  std::vector<uint32_t> order(keys_.size());
  for (uint32_t k = 0; k < order.size(); ++k) order[k] = k;
  if (budget < order.size()) {
    // One strict total order (key, then candidate index) for every budget: the selections nest.
    const auto before = [&](uint32_t a, uint32_t b) {
      return keys_[a] < keys_[b] || (keys_[a] == keys_[b] && a < b);
    };
    std::nth_element(order.begin(), order.begin() + budget, order.end(), before);
    order.resize(budget);
    std::sort(order.begin(), order.end());
  }
  for (uint32_t& k : order) k *= stride_;
  return order;
}

}  // namespace dysa
