// View-dependent detail: which particles a budgeted stream with a camera sends.
//
// Each candidate particle (id % stride == 0) gets a key
//
//     key(p) = rank(id) / 2^32 / w(cell of p)
//
// with rank the particle's fixed pseudo-random rank (codec::DetailRank, uniform in [0, 2^32)) and
// w the weight of the coarse grid cell it lies in. A budget of B particles sends the B smallest
// keys. Within one cell that is "rank below a per-cell threshold" (the codec's format-3 rule with
// a threshold per cell, t_c = s w_c 2^32 for the scale s the budget fixes), so the subset stays a
// uniform sample inside each cell; across cells the kept fraction follows w. Taking the B
// smallest keys of one ordering makes the subsets
// - nested: for one view and one frame, a larger budget adds particles and never drops one (the
//   server's progressive completion sends the difference);
// - exact: never more than B particles, whatever the random ranks do;
// - stable: the keys change only when the view, the budget or a particle's cell does, and the
//   server only re-selects at keyframes or when the view changes (FrameHub), so delta coding
//   still pays between them.
//
// The weight aims at an even density on the screen: a cell of edge h at distance d covers about
// (h / d)^2 of the image (in units of the squared focal length), and its n particles should get
// a share of the budget in proportion to that area, so w = (h / d)^2 / n (d >= h: the cell the
// eye is in is as dense as the nearest one). Cells outside the view frustum keep kOutsideWeight of
// the weight they would have in view: a coarse budget, so a turn of the camera shows a sparse
// fluid at once rather than an empty box until the next frame comes.
//
// The decoder does not need any of this: the ids travel with the subset (codec format 4).
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "dysa/core/view_selection.h"

namespace dysa::service {

// A subscriber's camera, in the scene's frame (metres). A right-handed look-at: the view
// direction is target - eye; `up` need not be orthogonal to it, only not parallel.
struct StreamView {
  std::array<double, 3> eye{};     // m
  std::array<double, 3> target{};  // m, a point the camera looks at
  std::array<double, 3> up{0, 1, 0};
  double fov_y_deg = 45;  // vertical field of view, degrees, [1, 179]
  double aspect = 1;      // viewport width / height, [0.05, 20]

  // Throws std::invalid_argument naming the field and its allowed range.
  void Validate() const;
  bool operator==(const StreamView&) const = default;
};

// The request that chooses a view's subset (dysa/core/view_selection.h): the grid over the
// domain box (degenerate axes: the particles' bounds) and the view's per-cell weights (see
// above). ViewOrder's on the host; Simulation::ReadViewSubset's on any device, where a GPU
// chooses the same ids on the device. `view` must be valid. `in_view`, when given, receives per
// cell whether it is in view at each selection (it must outlive the request's use).
ViewSubsetRequest ViewRequest(const StreamView& view, std::array<double, 3> domain_min,
                              std::array<double, 3> domain_max, uint32_t stride,
                              std::vector<uint8_t>* in_view = nullptr);

// The grid and the candidates' keys of one frame seen from one view, on the host.
class ViewOrder {
 public:
  static constexpr int kGrid = kViewGrid;             // cells per axis over the domain box
  static constexpr double kOutsideWeight = 1.0 / 16;  // a cell out of view: 1/4 of the spacing

  // `positions`: 3 per particle in id order (m); the box the grid spans (when degenerate, the
  // particles' bounding box). `view` must be valid.
  ViewOrder(const StreamView& view, std::span<const float> positions,
            std::array<double, 3> domain_min, std::array<double, 3> domain_max, uint32_t stride);

  // Candidates: ids with id % stride == 0.
  uint32_t candidates() const { return keys_.candidates(); }
  // The `budget` smallest keys' ids, increasing (every candidate when budget >= candidates()).
  std::vector<uint32_t> Select(uint64_t budget) const { return keys_.Select(budget); }
  // Whether the particle's cell is (at least partly) inside the view frustum.
  bool InView(uint32_t id) const { return in_view_[keys_.cell_of(id / keys_.stride())] != 0; }

 private:
  std::vector<uint8_t> in_view_;  // per cell (filled while keys_ is built)
  ViewKeys keys_;
};

}  // namespace dysa::service
