#include "components.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "octahedral_velocity.h"

namespace dysa::codec {
namespace {

// One component: see GatherComponents.
std::pair<float, float> GatherComponent(const FrameInput& f, Component c, uint32_t stride,
                                        const uint32_t* kept, uint32_t count, bool octahedral,
                                        float* out) {
  // The id of the k-th particle sent.
  const auto id = [&](int64_t k) { return kept ? size_t(kept[k]) : size_t(k) * stride; };
  float mn = std::numeric_limits<float>::infinity();
  float mx = -std::numeric_limits<float>::infinity();
  const int64_t n = count;
  if (n == 0) return {mn, mx};  // the arrays may be empty: no pointer arithmetic on them
  if (c == kSpeedC) {
    const float* v = f.velocities.data();
#pragma omp parallel for reduction(min : mn) reduction(max : mx) schedule(static)
    for (int64_t k = 0; k < n; ++k) {
      const size_t i = 3 * id(k);
      const double x = v[i], y = v[i + 1], z = v[i + 2];
      out[k] = float(std::sqrt(x * x + y * y + z * z));
      mn = std::min(mn, out[k]);
      mx = std::max(mx, out[k]);
    }
    return {mn, mx};
  }
  if (IsVelocity(c) && octahedral) {
    const float* v = f.velocities.data();
    const int slot = c - kVelX;
#pragma omp parallel for reduction(min : mn) reduction(max : mx) schedule(static)
    for (int64_t k = 0; k < n; ++k) {
      const size_t i = 3 * id(k);
      out[k] = float(ToOctahedral(v[i], v[i + 1], v[i + 2])[slot]);
      mn = std::min(mn, out[k]);
      mx = std::max(mx, out[k]);
    }
    return {mn, mx};
  }
  const float* src = c <= kPosZ       ? f.positions.data() + c
                     : c == kDensityC ? f.densities.data()
                                      : f.velocities.data() + (c - kVelX);
  const size_t step = c == kDensityC ? 1 : 3;
#pragma omp parallel for reduction(min : mn) reduction(max : mx) schedule(static)
  for (int64_t k = 0; k < n; ++k) {
    out[k] = src[id(k) * step];
    mn = std::min(mn, out[k]);
    mx = std::max(mx, out[k]);
  }
  return {mn, mx};
}

}  // namespace

size_t CheckInput(const FrameInput& f, uint32_t fields) {
  const size_t ids = f.positions.size() / 3;
  if (f.positions.size() != 3 * ids) throw std::invalid_argument("positions: size not 3 * count");
  if ((fields & (kSpeed | kVelocity)) && f.velocities.size() != 3 * ids) {
    throw std::invalid_argument("velocities: 3 * count values needed for speed or velocity");
  }
  if ((fields & kDensity) && f.densities.size() != ids) {
    throw std::invalid_argument("densities: count values needed for density");
  }
  return ids;
}

void CheckIds(std::span<const uint32_t> ids, size_t count) {
  for (size_t k = 0; k < ids.size(); ++k) {
    if (ids[k] >= count || (k > 0 && ids[k] <= ids[k - 1])) {
      throw std::invalid_argument("ids: strictly increasing, each in [0, " + std::to_string(count) +
                                  ")");
    }
  }
}

void WidenPositionsToAll(const FrameInput& f, Extremes& e) {
  const int64_t n = int64_t(f.positions.size() / 3);
  if (f.has_position_bounds) {  // the caller reduced them where the particles live
    for (int a = 0; a < 3; ++a) {
      if (n > 0) e.lo[a] = f.position_lo[a], e.hi[a] = f.position_hi[a];
    }
    return;
  }
  const float* p = f.positions.data();
  for (int a = 0; a < 3; ++a) {
    float mn = std::numeric_limits<float>::infinity();
    float mx = -std::numeric_limits<float>::infinity();
#pragma omp parallel for reduction(min : mn) reduction(max : mx) schedule(static)
    for (int64_t i = 0; i < n; ++i) {
      mn = std::min(mn, p[3 * i + a]);
      mx = std::max(mx, p[3 * i + a]);
    }
    if (n > 0) e.lo[a] = mn, e.hi[a] = mx;
  }
}

Extremes GatherComponents(const FrameInput& f, std::span<const Component> comps, uint32_t stride,
                          std::span<const uint32_t> kept, uint32_t count, bool octahedral,
                          std::vector<std::vector<float>>& values) {
  Extremes e;
  values.resize(kComponents);
  for (Component c : comps) {
    values[c].resize(count);
    const auto [mn, mx] = GatherComponent(f, c, stride, kept.empty() ? nullptr : kept.data(), count,
                                          octahedral, values[c].data());
    e.lo[c] = mn;
    e.hi[c] = mx;
  }
  return e;
}

}  // namespace dysa::codec
