// Uniform-grid neighbour search with a counting sort of particles by cell.
//
// Cells are cubes of edge >= support / r for a reach r of 1 or more (cells_per_support), so
// every neighbour of a particle within the support lies in the block of (2r + 1)^3 cells around
// it. Cells are numbered x-fastest; the 2r + 1 cells of the block that share (y, z) are
// consecutive, so after particles are sorted by cell the block is (2r + 1)^2 contiguous runs of
// particle indices. A finer grid (r = 2) tests fewer candidates per neighbour: the block holds
// (5/2)^3 = 15.6 support-cubes of candidates instead of 27, for 25 runs instead of 9.
//
// Particles outside the domain are clamped, axis by axis, into the border cells. Clamping never
// moves two points more than r cells apart along an axis if they were not already, so the
// search stays exact for any position; a non-finite coordinate goes to cell 0.
//
// Along a periodic axis the domain's length L is tiled by a whole number (at least 2r + 1) of
// cells, each at least the requested edge, so cells are then cuboids. The cells beyond either
// end wrap around, and the run query says by how much to move the query point to meet the
// neighbours' image nearest to it (the minimum image): a particle at x near the upper end sees
// one at x' near the lower end at distance x' + L - x.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
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
  // The most particles one cell may hold for a step to cost a bounded multiple of a normal one:
  // a neighbour pass tests the particles of 27 cells, so its cost per particle grows with the
  // cell's occupancy, and particles collapsed into one cell make a step O(n^2) (40,000 particles
  // at one point took minutes a step). A fluid at rest holds 8 particles a cell (wcsph, dfsph:
  // edge 2 d) and the thesis scene about 13 (seed): 1,024 is 40 to 130 times that, a step at
  // most about 100 times a normal one. Scenes that would exceed it are refused
  // (BlockParticleCounts), and a step that finds a cell over it stops with an alarm.
  static constexpr uint32_t kMaxParticlesPerCell = 1024;

  // The largest reach (cells_per_support) a grid takes.
  static constexpr int kMaxReach = 2;
  // Lays cells of edge >= support / cells_per_support over the domain, wrapping along the axes
  // marked periodic; the run queries then visit the (2 cells_per_support + 1)^3 cells around a
  // point. A periodic axis needs room for 2 cells_per_support + 1 cells: throws
  // std::invalid_argument when its length is under that many (Model validation rejects such
  // scenes first, naming them), or for a cells_per_support outside [1, kMaxReach].
  void Configure(const Aabb& domain, Real support, const Periodicity& periodic = {},
                 int cells_per_support = 1);

  // Stable counting sort of the points by cell in O(n + cells). Afterwards order()[k] is the
  // index in `points` of the k-th point in cell order; the caller permutes its arrays with it
  // (PermuteInPlace), and the run queries below refer to that sorted order.
  void Sort(std::span<const Vec3> points);

  std::span<const uint32_t> order() const { return order_; }
  // The most points any cell holds after the latest Sort.
  uint32_t max_cell_count() const { return max_cell_count_; }
  // The sorted points as separate coordinate arrays, for vectorised neighbour loops. Each holds
  // kPadding readable zeros past its end, so a loop may load whole vectors at a run's end.
  static constexpr int kPadding = 8;
  std::span<const Real> xs() const { return {xs_.data(), order_.size()}; }
  std::span<const Real> ys() const { return {ys_.data(), order_.size()}; }
  std::span<const Real> zs() const { return {zs_.data(), order_.size()}; }
  // The smallest cell edge (>= support / reach); along a periodic axis cells may be longer.
  Real cell_size() const { return Real(cell_.minCoeff()); }
  // How many cells either side of a point's own the run queries visit (cells_per_support).
  int reach() const { return reach_; }
  Vec3d cell_sizes() const { return cell_; }
  // What CellOf computes with (for a GPU grid that must agree with this one bit for bit).
  Vec3d origin() const { return origin_; }
  Vec3d inv_cell_sizes() const { return inv_cell_; }
  Vec3 periods() const { return period_; }
  Eigen::Vector3i dims() const { return dims_; }
  const Periodicity& periodic() const { return periodic_; }
  int64_t cell_count() const { return int64_t{dims_.x()} * dims_.y() * dims_.z(); }

  // In double, with a cell edge a hair longer than the requested size: two points closer than
  // that size then always land in the same or adjacent cells, whatever the float rounding
  // (in float, (x - origin) / h can put points 0.99999 h apart two cells apart).
  Eigen::Vector3i CellOf(const Vec3& p) const {
    Eigen::Vector3i c;
    for (int a = 0; a < 3; ++a) {
      double f = (double(p[a]) - origin_[a]) * inv_cell_[a];
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

  // Calls visit(begin, end, shift) for each non-empty run of sorted indices in the block of
  // (2 reach + 1)^3 cells around `cell`, in a fixed order (z, then y; x within a run, the cells
  // wrapped across a periodic x seam as one run after the others). `shift` is what to add to the
  // query point to measure its distance to the run's points: zero, or +-L along the periodic axes
  // whose cells wrapped (x_ij = x + shift - x_j).
  template <class Visit>
  void ForEachNeighborRun(const Eigen::Vector3i& cell, Visit&& visit) const {
    const int r = reach_;
    // The x range without wrapping; a periodic x at either end adds the cells across the seam.
    const int x0 = std::max(cell.x() - r, 0);
    const int x1 = std::min(cell.x() + r, dims_.x() - 1);
    if (!any_periodic_) {
      // Without periodic axes, the plain loop (the wrapping's branches cost the seed solver's
      // step 10%, seed_step_bench).
      const Vec3 zero = Vec3::Zero();
      for (int z = std::max(cell.z() - r, 0); z <= std::min(cell.z() + r, dims_.z() - 1); ++z) {
        for (int y = std::max(cell.y() - r, 0); y <= std::min(cell.y() + r, dims_.y() - 1); ++y) {
          const uint32_t row = uint32_t(dims_.x()) * (y + uint32_t(dims_.y()) * z);
          const uint32_t begin = cell_start_[row + x0];
          const uint32_t end = cell_start_[row + x1 + 1];
          if (begin < end) visit(begin, end, zero);
        }
      }
      return;
    }
    // The wrapped x cells [wrap_x0, wrap_x1], when the block crosses a periodic x seam (a grid
    // of at least 2r + 1 cells crosses at most one).
    int wrap_x0 = -1, wrap_x1 = -1;
    Real shift_x = 0;
    if (periodic_[0]) {
      if (cell.x() - r < 0) {
        wrap_x0 = dims_.x() + cell.x() - r, wrap_x1 = dims_.x() - 1, shift_x = period_[0];
      } else if (cell.x() + r > dims_.x() - 1) {
        wrap_x0 = 0, wrap_x1 = cell.x() + r - dims_.x(), shift_x = -period_[0];
      }
    }
    for (int dz = -r; dz <= r; ++dz) {
      int z = cell.z() + dz;
      Real shift_z = 0;
      if (!Wrap(2, z, shift_z)) continue;
      for (int dy = -r; dy <= r; ++dy) {
        int y = cell.y() + dy;
        Real shift_y = 0;
        if (!Wrap(1, y, shift_y)) continue;
        const Vec3 shift(0, shift_y, shift_z);
        const uint32_t row = uint32_t(dims_.x()) * (y + uint32_t(dims_.y()) * z);
        const uint32_t begin = cell_start_[row + x0];
        const uint32_t end = cell_start_[row + x1 + 1];
        if (begin < end) visit(begin, end, shift);
        if (wrap_x0 >= 0) {
          const uint32_t wrap_begin = cell_start_[row + wrap_x0];
          const uint32_t wrap_end = cell_start_[row + wrap_x1 + 1];
          if (wrap_begin < wrap_end) visit(wrap_begin, wrap_end, Vec3(shift_x, shift_y, shift_z));
        }
      }
    }
  }

 private:
  // Cell index c + offset along `axis` brought into the grid: false when it lies outside a
  // non-periodic axis; across a periodic one it wraps, and `shift` takes the query point to the
  // image (+L below the grid, -L above it).
  bool Wrap(int axis, int& c, Real& shift) const {
    if (c >= 0 && c < dims_[axis]) return true;
    if (!periodic_[axis]) return false;
    shift = c < 0 ? period_[axis] : -period_[axis];
    c += c < 0 ? dims_[axis] : -dims_[axis];
    return true;
  }

  Vec3d origin_ = Vec3d::Zero();
  Vec3d cell_ = Vec3d::Ones();      // m, edge of a cell along each axis
  Vec3d inv_cell_ = Vec3d::Ones();  // 1/m
  Eigen::Vector3i dims_{1, 1, 1};
  int reach_ = 1;  // cells either side that the run queries visit
  Periodicity periodic_{};
  bool any_periodic_ = false;
  Vec3 period_ = Vec3::Zero();        // m, the domain's length along each periodic axis
  std::vector<uint32_t> key_;         // cell of each point, input order
  std::vector<uint32_t> sorted_key_;  // cell of each point, sorted order
  std::vector<uint32_t> order_;       // sorted position -> input index
  std::vector<uint32_t> cell_start_;  // cells + 1 entries; cell c holds [start[c], start[c+1])
  std::vector<uint32_t> cursor_;      // fill position of each cell during the sort
  uint32_t max_cell_count_ = 0;
  std::vector<Real> xs_, ys_, zs_;  // sorted points, padded
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
