#include "quantisation.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "octahedral_velocity.h"

namespace dysa::codec {
namespace {

// The nearest level (ties up) to v, clamped to [0, levels]; NaN gives 0. `scale` is
// levels / (hi - lo). Branch-free so the loop over a component vectorises.
uint32_t Quantize(double v, double lo, double scale, uint32_t levels) {
  double x = (v - lo) * scale + 0.5;
  x = x >= 0 ? x : 0;  // also NaN
  x = x <= double(levels) ? x : double(levels);
  return uint32_t(x);
}

float Dequantize(uint32_t q, double lo, double step) { return float(lo + double(q) * step); }

// Half a quantisation step plus float rounding: of the decoded value, and of the speed, which is
// rounded to float before it is quantised (half a float ulp of the range's magnitude each).
double ErrorBound(double lo, double hi, int bits) {
  const double half_step = 0.5 * (hi - lo) / double(Levels(bits));
  const double magnitude = std::max(std::abs(lo), std::abs(hi));
  return half_step + magnitude * std::numeric_limits<float>::epsilon();
}

}  // namespace

Values TakeValues(std::vector<Values>& spare, uint32_t count, const ChunkHeader& h) {
  Values q;
  if (!spare.empty()) {
    q = std::move(spare.back());
    spare.pop_back();
  }
  q.resize(kComponents);
  for (int c = 0; c < kComponents; ++c) {
    if (h.Has(Component(c)))
      q[c].resize(count);  // no zeroing when the size is unchanged
    else
      q[c].clear();
  }
  return q;
}

bool LeavesRanges(const Extremes& e, std::span<const Component> comps, uint32_t count,
                  const std::array<double, kComponents>& lo,
                  const std::array<double, kComponents>& hi) {
  bool leaves = false;
  for (Component c : comps) leaves |= count > 0 && (e.lo[c] < lo[c] || e.hi[c] > hi[c]);
  return leaves;
}

void ChooseRanges(const FrameInput& f, std::span<const Component> comps, bool octahedral,
                  uint32_t count, Extremes e, std::array<double, kComponents>& lo,
                  std::array<double, kComponents>& hi) {
  // An empty frame has no extremes: any valid range will do.
  if (count == 0) e.lo.fill(0), e.hi.fill(1);
  for (Component c : comps) {
    double a = e.lo[c], b = e.hi[c];
    if (c <= kPosZ) {
      // The domain when particles are inside it (walls keep them there); with headroom
      // where they are not.
      const bool has_domain = f.domain_max[c] > f.domain_min[c];
      const bool inside = has_domain && a >= f.domain_min[c] && b <= f.domain_max[c];
      const double margin = inside ? 0.0 : 0.05 * (b - a) + 1e-3;
      a = (has_domain ? std::min(a, f.domain_min[c]) : a) - margin;
      b = (has_domain ? std::max(b, f.domain_max[c]) : b) + margin;
    } else if (c == kSpeedC) {
      a = 0;
      b = std::max(1.25 * b, 1e-3);
    } else if (c == kDensityC) {
      const double margin = 0.1 * (b - a) + std::max(1e-3, 1e-3 * std::abs(b));
      a -= margin;
      b += margin;
    } else if (octahedral) {
      // |v| like speed; the octahedral coordinates always lie in [-1, 1].
      a = c == kVelX ? 0.0 : -1.0;
      b = c == kVelX ? std::max(1.25 * b, 1e-3) : 1.0;
    } else {
      // One range for the three components (the header has one velocity_max).
      b = 1e-3;
      for (int v = kVelX; v <= kVelZ; ++v) {
        b = std::max({b, 1.25 * std::abs(e.lo[v]), 1.25 * std::abs(e.hi[v])});
      }
      a = -b;
    }
    lo[c] = a;
    hi[c] = b;
  }
}

void QuantizeComponents(const ChunkHeader& h, std::span<const Component> comps,
                        const std::vector<std::vector<float>>& values, uint32_t count, Values& q) {
  for (Component c : comps) {
    const uint32_t levels = Levels(h.Bits(c));
    const double a = h.Lo(c), b = h.Hi(c);
    const float* v = values[c].data();
    uint32_t* out = q[c].data();
    const double scale = double(levels) / (b - a);
#pragma omp parallel for schedule(static)
    for (int64_t k = 0; k < int64_t(count); ++k) out[k] = Quantize(v[k], a, scale, levels);
  }
}

void DequantizeComponent(const ChunkHeader& h, Component c, const Values& q, Frame& frame) {
  const uint32_t m = h.chunk_particles;
  if (m == 0) return;  // an empty frame: its arrays may be empty
  const uint32_t* cur = q[c].data() + h.first;
  const double lo = h.Lo(c);
  const double step = (h.Hi(c) - lo) / double(Levels(h.Bits(c)));
  float* out = c <= kPosZ       ? frame.positions.data() + 3 * size_t(h.first) + c
               : c == kSpeedC   ? frame.speed.data() + h.first
               : c == kDensityC ? frame.densities.data() + h.first
                                : frame.velocities.data() + 3 * size_t(h.first) + (c - kVelX);
  const size_t out_stride = (c <= kPosZ || IsVelocity(c)) ? 3 : 1;
  for (uint32_t k = 0; k < m; ++k) out[k * out_stride] = Dequantize(cur[k], lo, step);
}

void SetErrorBounds(const ChunkHeader& h, Frame& frame) {
  for (int a = 0; a < 3; ++a) {
    frame.position_error[a] = ErrorBound(h.position_min[a], h.position_max[a], h.position_bits);
  }
  frame.speed_error = (h.fields & kSpeed) ? ErrorBound(0, h.speed_max, h.speed_bits) : 0;
  frame.velocity_error = 0;
  if (h.fields & kVelocity) {
    frame.velocity_error = h.octahedral()
                               ? OctahedralErrorBound(h.velocity_max, h.velocity_bits)
                               : ErrorBound(-h.velocity_max, h.velocity_max, h.velocity_bits);
  }
  frame.density_error =
      (h.fields & kDensity) ? ErrorBound(h.density_min, h.density_max, h.density_bits) : 0;
}

}  // namespace dysa::codec
