// Uniform-grid neighbour search with a counting sort of particles by cell.
//
// Cells are cubes of edge >= the smoothing radius h, so every neighbour of a particle within h
// lies in the 3x3x3 block of cells around it. Cells are numbered x-fastest; the three cells of
// the block that share (y, z) are consecutive, so after particles are sorted by cell the block
// is 9 contiguous runs of particle indices rather than 27.
//
// Particles outside the domain are clamped, axis by axis, into the border cells. Clamping never
// moves two points more than one cell apart along an axis if they were not already, so the
// search stays exact for any position; a non-finite coordinate goes to cell 0.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "dysa/core/types.h"

namespace dysa {

class NeighborGrid {
 public:
  // Bounds the cell count: on a fine grid over a large domain the cell edge grows beyond
  // min_cell_size (which stays correct, only slower) rather than allocating without limit.
  static constexpr int64_t kMaxCells = 1 << 24;

  // Lays cells of edge >= min_cell_size over the domain.
  void Configure(const Aabb& domain, Real min_cell_size);

  // Stable counting sort of the points by cell in O(n + cells). Afterwards order()[k] is the
  // index in `points` of the k-th point in cell order; the caller permutes its arrays with it
  // (PermuteInPlace), and the run queries below refer to that sorted order.
  void Sort(std::span<const Vec3> points);

  std::span<const uint32_t> order() const { return order_; }
  // The sorted points as separate coordinate arrays, for vectorised neighbour loops. Each holds
  // kPadding readable zeros past its end, so a loop may load whole vectors at a run's end.
  static constexpr int kPadding = 8;
  std::span<const Real> xs() const { return {xs_.data(), order_.size()}; }
  std::span<const Real> ys() const { return {ys_.data(), order_.size()}; }
  std::span<const Real> zs() const { return {zs_.data(), order_.size()}; }
  Real cell_size() const { return cell_size_; }
  Eigen::Vector3i dims() const { return dims_; }
  int64_t cell_count() const { return int64_t{dims_.x()} * dims_.y() * dims_.z(); }

  // In double, with a cell edge a hair longer than the requested size: two points closer than
  // that size then always land in the same or adjacent cells, whatever the float rounding
  // (in float, (x - origin) / h can put points 0.99999 h apart two cells apart).
  Eigen::Vector3i CellOf(const Vec3& p) const {
    Eigen::Vector3i c;
    for (int a = 0; a < 3; ++a) {
      double f = (double(p[a]) - origin_[a]) * inv_cell_size_;
      // Clamp before the cast: the cast of a huge or NaN value is undefined. (std::clamp, not
      // fmin/fmax: those are library calls here, NaN being handled already.)
      f = std::isnan(f) ? 0.0 : std::clamp(f, 0.0, double(dims_[a] - 1));
      c[a] = static_cast<int>(f);
    }
    return c;
  }
  uint32_t CellIndex(const Eigen::Vector3i& c) const {
    return static_cast<uint32_t>(c.x() + dims_.x() * (c.y() + dims_.y() * c.z()));
  }
  // The cell of the k-th particle in sorted order.
  Eigen::Vector3i SortedCell(uint32_t k) const {
    const uint32_t key = sorted_key_[k];
    return {static_cast<int>(key % dims_.x()), static_cast<int>((key / dims_.x()) % dims_.y()),
            static_cast<int>(key / (uint32_t(dims_.x()) * dims_.y()))};
  }

  // Calls visit(begin, end) for each non-empty run of sorted indices in the 3x3x3 block of
  // cells around `cell`, in a fixed order (z, then y; x within a run).
  template <class Visit>
  void ForEachNeighborRun(const Eigen::Vector3i& cell, Visit&& visit) const {
    const int x0 = cell.x() > 0 ? cell.x() - 1 : 0;
    const int x1 = cell.x() + 1 < dims_.x() ? cell.x() + 1 : dims_.x() - 1;
    for (int z = cell.z() - 1; z <= cell.z() + 1; ++z) {
      if (z < 0 || z >= dims_.z()) continue;
      for (int y = cell.y() - 1; y <= cell.y() + 1; ++y) {
        if (y < 0 || y >= dims_.y()) continue;
        const uint32_t row = uint32_t(dims_.x()) * (y + uint32_t(dims_.y()) * z);
        const uint32_t begin = cell_start_[row + x0];
        const uint32_t end = cell_start_[row + x1 + 1];
        if (begin < end) visit(begin, end);
      }
    }
  }

 private:
  Vec3d origin_ = Vec3d::Zero();
  Real cell_size_ = 1;
  double inv_cell_size_ = 1;
  Eigen::Vector3i dims_{1, 1, 1};
  std::vector<uint32_t> key_;         // cell of each point, input order
  std::vector<uint32_t> sorted_key_;  // cell of each point, sorted order
  std::vector<uint32_t> order_;       // sorted position -> input index
  std::vector<uint32_t> cell_start_;  // cells + 1 entries; cell c holds [start[c], start[c+1])
  std::vector<uint32_t> cursor_;      // fill position of each cell during the sort
  std::vector<Real> xs_, ys_, zs_;    // sorted points, padded
};

// out[k] = in[order[k]] for every k, in parallel; then swaps out into in.
template <class T>
void PermuteInPlace(std::span<const uint32_t> order, std::vector<T>& data,
                    std::vector<T>& scratch) {
  const int64_t n = static_cast<int64_t>(order.size());
  scratch.resize(order.size());
#pragma omp parallel for schedule(static)
  for (int64_t k = 0; k < n; ++k) scratch[k] = data[order[k]];
  data.swap(scratch);
}

}  // namespace dysa
