#include "dysa/core/neighbor_grid.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace dysa {

void NeighborGrid::Configure(const Aabb& domain, Real support, const Periodicity& periodic,
                             int cells_per_support) {
  if (cells_per_support < 1 || cells_per_support > kMaxReach) {
    throw std::invalid_argument("NeighborGrid: cells_per_support must be 1 or 2");
  }
  const int reach = cells_per_support;
  const int min_dims = 2 * reach + 1;  // along a periodic axis: no cell met twice in a block
  const double min_cell_size = double(support) / reach;
  const Vec3d size = domain.Size();
  // 1e-6 relative covers the float rounding of the distance tests and the double rounding of
  // CellOf for any grid under kMaxCells cells per axis.
  double cell = min_cell_size * (1 + 1e-6);
  // Grow the cell edge until the grid fits in kMaxCells (a cube root estimate, then a guard for
  // rounding up of the per-axis counts).
  const double estimate = std::cbrt(size.prod() / double(kMaxCells));
  cell = std::max(cell, estimate);
  Eigen::Vector3i dims;
  for (;;) {
    for (int a = 0; a < 3; ++a) {
      // A periodic axis is tiled exactly: its cells are stretched to L / floor(L / cell).
      dims[a] =
          std::max(1, int(periodic[a] ? std::floor(size[a] / cell) : std::ceil(size[a] / cell)));
    }
    if (int64_t{dims.x()} * dims.y() * dims.z() <= kMaxCells) break;
    cell *= 1.01;
  }
  for (int a = 0; a < 3; ++a) {
    // A period of exactly 2r + 1 cell edges loses its last cell to the margin above; with
    // 2r + 1 cells each one lies within r of the others across the seam, so rounding cannot
    // split a pair.
    if (periodic[a] && dims[a] < min_dims && size[a] >= min_dims * min_cell_size * (1 - 1e-6)) {
      dims[a] = min_dims;
    }
    if (periodic[a] && dims[a] < min_dims) {
      throw std::invalid_argument("NeighborGrid: a periodic axis needs at least " +
                                  std::to_string(min_dims) + " cells");
    }
    cell_[a] = periodic[a] ? size[a] / dims[a] : cell;
    inv_cell_[a] = 1.0 / cell_[a];
    period_[a] = periodic[a] ? Real(size[a]) : Real(0);
  }
  origin_ = domain.min;
  dims_ = dims;
  reach_ = reach;
  periodic_ = periodic;
  any_periodic_ = periodic[0] || periodic[1] || periodic[2];
}

void NeighborGrid::Sort(std::span<const Vec3> points) {
  const int64_t n = static_cast<int64_t>(points.size());
  key_.resize(points.size());
  sorted_key_.resize(points.size());
  order_.resize(points.size());
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) key_[i] = CellIndex(CellOf(points[i]));

  // Counting sort, serial: it is O(n + cells) of simple integer work, a few percent of a step;
  // visiting points in input order makes it stable, so the order depends on positions alone.
  const size_t cells = static_cast<size_t>(cell_count());
  cell_start_.assign(cells + 1, 0);
  for (int64_t i = 0; i < n; ++i) ++cell_start_[key_[i] + 1];
  max_cell_count_ = 0;
  for (size_t c = 0; c < cells; ++c) {
    max_cell_count_ = std::max(max_cell_count_, cell_start_[c + 1]);
    cell_start_[c + 1] += cell_start_[c];
  }
  // cell_start_[c] now is the first slot of cell c; use a copy as the fill cursor.
  cursor_.assign(cell_start_.begin(), cell_start_.end() - 1);
  for (int64_t i = 0; i < n; ++i) order_[cursor_[key_[i]]++] = static_cast<uint32_t>(i);

  for (std::vector<Real>* coords : {&xs_, &ys_, &zs_}) {
    coords->resize(points.size() + kPadding);
    std::fill(coords->end() - kPadding, coords->end(), Real(0));
  }
#pragma omp parallel for schedule(static)
  for (int64_t k = 0; k < n; ++k) {
    const uint32_t i = order_[k];
    sorted_key_[k] = key_[i];
    xs_[k] = points[i].x();
    ys_[k] = points[i].y();
    zs_[k] = points[i].z();
  }
}

}  // namespace dysa
