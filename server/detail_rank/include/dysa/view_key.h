// A view stream's per-particle key, one definition for the host and the GPU.
//
// View-dependent detail (dysa/service/view_detail.h) gives each candidate particle the key
//
//     key(p) = rank(id) / 2^32 / w(cell of p)
//
// over a coarse grid of kViewGrid^3 cells spanning a box, and a budget of B sends the B smallest
// keys (ties: the smaller id first). The per-cell weights w depend on the camera and on how many
// candidates each cell holds; they are computed on the host from the cells' counts (the service's
// ViewOrder). What depends on each particle (its cell and its key) is computed here, by the
// service's ViewOrder on the host and by the core's CUDA kernel (cuda/view_subset.cu) on the
// device. Every step is one correctly rounded IEEE double operation (a subtraction, a division,
// floor, a product by a power of two, the conversion to float) with no multiply-add to fuse, so
// both compute the same bits and choose the same ids.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>

#include "dysa/detail_rank.h"

namespace dysa {

inline constexpr int kViewGrid = 32;  // cells per axis
inline constexpr uint32_t kViewCells = uint32_t(kViewGrid) * kViewGrid * kViewGrid;  // 32768

// The grid: its low corner and its cells' edges (m). Cell (i, j, k) is cell index
// (k * kViewGrid + j) * kViewGrid + i.
struct ViewGrid {
  double lo[3] = {0, 0, 0};
  double edge[3] = {1, 1, 1};
};

// The grid over [box_min, box_max]; on an axis where that box is degenerate (max <= min), over
// the particles' bounds on it instead, [particle_min, particle_max] (the smallest and largest
// non-NaN coordinate of the n particles; +inf and -inf when none), and a unit span around them
// when those are degenerate too (around -0.5 .. 0.5 without particles). Host only.
inline ViewGrid MakeViewGrid(const double box_min[3], const double box_max[3],
                             const double particle_min[3], const double particle_max[3], size_t n) {
  ViewGrid g;
  for (int a = 0; a < 3; ++a) {
    double lo = box_min[a], hi = box_max[a];
    if (!(hi > lo)) {
      lo = particle_min[a];
      hi = particle_max[a];
      if (!(hi > lo)) lo = (n ? lo : 0) - 0.5, hi = lo + 1;
    }
    g.lo[a] = lo;
    g.edge[a] = (hi - lo) / kViewGrid;
  }
  return g;
}

// The cell of a particle at (x, y, z): per axis floor((x - lo) / edge) clamped to the grid (0 for
// a coordinate that is not finite, or whose quotient is not).
DYSA_HOST_DEVICE inline uint32_t ViewCellOf(const ViewGrid& g, float x, float y, float z) {
  const float p[3] = {x, y, z};
  uint32_t cell = 0;
  for (int a = 2; a >= 0; --a) {
    double c = floor((double(p[a]) - g.lo[a]) / g.edge[a]);
    // Not finite (NaN fails both comparisons): 0; then clamped to [0, kViewGrid - 1].
    if (!(c >= -1.7976931348623157e308 && c <= 1.7976931348623157e308)) c = 0;
    c = c < 0 ? 0.0 : (c > kViewGrid - 1 ? double(kViewGrid - 1) : c);
    cell = cell * kViewGrid + uint32_t(c);
  }
  return cell;
}

// The key of particle `id` in a cell of weight `weight` (> 0): its rank in [0, 1) over the weight,
// rounded to float.
DYSA_HOST_DEVICE inline float ViewKey(uint32_t id, double weight) {
  const double rank = double(DetailRank(id)) * 0x1.0p-32;
  return float(rank / weight);
}

}  // namespace dysa
