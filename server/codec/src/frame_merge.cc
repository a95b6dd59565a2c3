#include "dysa/codec/frame_merge.h"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "dysa/codec/detail_subset.h"

namespace dysa::codec {
namespace {

// Appends particle k of `f` to `out`'s arrays.
void Append(const Frame& f, const std::vector<uint32_t>& ids, size_t k, Frame& out) {
  out.ids.push_back(ids[k]);
  out.positions.insert(out.positions.end(), f.positions.begin() + 3 * k,
                       f.positions.begin() + 3 * k + 3);
  if (!f.speed.empty()) out.speed.push_back(f.speed[k]);
  if (!f.velocities.empty()) {
    out.velocities.insert(out.velocities.end(), f.velocities.begin() + 3 * k,
                          f.velocities.begin() + 3 * k + 3);
  }
  if (!f.densities.empty()) out.densities.push_back(f.densities[k]);
}

}  // namespace

void MergeRefinement(Frame& shown, const Frame& more) {
  if (shown.fields != more.fields) {
    throw std::invalid_argument("refinement: fields differ from the frame shown");
  }
  const std::vector<uint32_t> a = ParticleIds(shown), b = ParticleIds(more);
  Frame out;
  out.frame_seq = more.frame_seq;
  out.step = more.step;
  out.time = more.time;
  out.keyframe = more.keyframe;
  out.stride = more.stride;
  // The detail grows with the particles: the shown frame's fraction times the growth (the
  // viewer sizes particles by it; the last refinement's caller sets 0, the full frame).
  const double fraction =
      shown.count == 0 ? 1.0
                       : std::min(1.0, DetailFraction(shown.detail_threshold) *
                                           double(a.size() + b.size()) / double(shown.count));
  out.detail_threshold = DetailThreshold(fraction);
  out.explicit_ids = true;
  out.fields = more.fields;
  out.velocity_encoding = more.velocity_encoding;
  for (int i = 0; i < 3; ++i) {
    out.position_error[i] = std::max(shown.position_error[i], more.position_error[i]);
  }
  out.speed_error = std::max(shown.speed_error, more.speed_error);
  out.velocity_error = std::max(shown.velocity_error, more.velocity_error);
  out.density_error = std::max(shown.density_error, more.density_error);
  const size_t n = a.size() + b.size();
  out.ids.reserve(n);
  out.positions.reserve(3 * n);
  size_t i = 0, j = 0;
  while (i < a.size() || j < b.size()) {
    if (i < a.size() && j < b.size() && a[i] == b[j]) {
      throw std::invalid_argument("refinement: particle " + std::to_string(a[i]) +
                                  " is already in the frame shown");
    }
    if (j == b.size() || (i < a.size() && a[i] < b[j])) {
      Append(shown, a, i++, out);
    } else {
      Append(more, b, j++, out);
    }
  }
  out.count = uint32_t(n);
  shown = std::move(out);
}

}  // namespace dysa::codec
