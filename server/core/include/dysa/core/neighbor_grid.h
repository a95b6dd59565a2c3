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
//
// Along a periodic axis the domain's length L is tiled by a whole number (at least 3) of cells,
// each at least the requested edge, so cells are then cuboids. The cells beyond either end wrap
// around, and the run query says by how much to move the query point to meet the neighbours'
// image nearest to it (the minimum image): a particle at x near the upper end sees one at x' near
// the lower end at distance x' + L - x.
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

  // Lays cells of edge >= min_cell_size over the domain, wrapping along the axes marked
  // periodic. A periodic axis needs room for 3 cells: throws std::invalid_argument when its
  // length is under 3 min_cell_size (Model validation rejects such scenes first, naming them).
  void Configure(const Aabb& domain, Real min_cell_size, const Periodicity& periodic = {});

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
  // The smallest cell edge (>= the requested size); along a periodic axis cells may be longer.
  Real cell_size() const { return Real(cell_.minCoeff()); }
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

  // Calls visit(begin, end, shift) for each non-empty run of sorted indices in the 3x3x3 block
  // of cells around `cell`, in a fixed order (z, then y; x within a run, a wrapped x cell after
  // the others). `shift` is what to add to the query point to measure its distance to the run's
  // points: zero, or +-L along the periodic axes whose cells wrapped (x_ij = x + shift - x_j).
  template <class Visit>
  void ForEachNeighborRun(const Eigen::Vector3i& cell, Visit&& visit) const {
    // The x range without wrapping; a periodic x at either end adds the cell across the seam.
    const int x0 = cell.x() > 0 ? cell.x() - 1 : 0;
    const int x1 = cell.x() + 1 < dims_.x() ? cell.x() + 1 : dims_.x() - 1;
    if (!any_periodic_) {
      // Without periodic axes, the plain loop (the wrapping's branches cost the seed solver's
      // step 10%, seed_step_bench).
      const Vec3 zero = Vec3::Zero();
      for (int z = std::max(cell.z() - 1, 0); z <= std::min(cell.z() + 1, dims_.z() - 1); ++z) {
        for (int y = std::max(cell.y() - 1, 0); y <= std::min(cell.y() + 1, dims_.y() - 1); ++y) {
          const uint32_t row = uint32_t(dims_.x()) * (y + uint32_t(dims_.y()) * z);
          const uint32_t begin = cell_start_[row + x0];
          const uint32_t end = cell_start_[row + x1 + 1];
          if (begin < end) visit(begin, end, zero);
        }
      }
      return;
    }
    int wrapped_x = -1;
    Real shift_x = 0;
    if (periodic_[0]) {
      if (cell.x() == 0) wrapped_x = dims_.x() - 1, shift_x = period_[0];
      if (cell.x() == dims_.x() - 1) wrapped_x = 0, shift_x = -period_[0];
    }
    for (int dz = -1; dz <= 1; ++dz) {
      int z = cell.z() + dz;
      Real shift_z = 0;
      if (!Wrap(2, z, shift_z)) continue;
      for (int dy = -1; dy <= 1; ++dy) {
        int y = cell.y() + dy;
        Real shift_y = 0;
        if (!Wrap(1, y, shift_y)) continue;
        const Vec3 shift(0, shift_y, shift_z);
        const uint32_t row = uint32_t(dims_.x()) * (y + uint32_t(dims_.y()) * z);
        const uint32_t begin = cell_start_[row + x0];
        const uint32_t end = cell_start_[row + x1 + 1];
        if (begin < end) visit(begin, end, shift);
        if (wrapped_x >= 0) {
          const uint32_t wrap_begin = cell_start_[row + wrapped_x];
          const uint32_t wrap_end = cell_start_[row + wrapped_x + 1];
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
