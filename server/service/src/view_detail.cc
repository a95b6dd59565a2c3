#include "dysa/service/view_detail.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "dysa/codec/detail_subset.h"

namespace dysa::service {
namespace {

using Vec = std::array<double, 3>;

Vec Sub(const Vec& a, const Vec& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
double Dot(const Vec& a, const Vec& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec Cross(const Vec& a, const Vec& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Vec Normalized(const Vec& a) {
  const double n = std::sqrt(Dot(a, a));
  return {a[0] / n, a[1] / n, a[2] / n};
}

void CheckVec(const Vec& v, const std::string& field) {
  for (double x : v) {
    if (!std::isfinite(x) || std::abs(x) > 1e6) {
      throw std::invalid_argument(field + ": each component finite, in [-1e6, 1e6] m");
    }
  }
}

// The camera's frame: forward, right and up unit vectors, and the frustum's four side planes as
// inward normals through the eye (a point at offset r from the eye is inside a side when
// Dot(n, r) >= 0).
struct Frustum {
  std::array<Vec, 4> normals;
  Vec eye;

  explicit Frustum(const StreamView& v) : eye(v.eye) {
    const Vec f = Normalized(Sub(v.target, v.eye));
    const Vec r = Normalized(Cross(f, v.up));
    const Vec u = Cross(r, f);
    const double half_y = 0.5 * v.fov_y_deg * std::acos(-1.0) / 180;
    const double half_x = std::atan(v.aspect * std::tan(half_y));
    // The right side's plane holds u and the edge direction cos(hx) f + sin(hx) r, so its inward
    // normal is sin(hx) f - cos(hx) r (orthogonal to both, positive along f); likewise the others.
    const auto side = [&](const Vec& axis, double half, double sign) {
      return Vec{std::sin(half) * f[0] - sign * std::cos(half) * axis[0],
                 std::sin(half) * f[1] - sign * std::cos(half) * axis[1],
                 std::sin(half) * f[2] - sign * std::cos(half) * axis[2]};
    };
    normals = {side(r, half_x, 1), side(r, half_x, -1), side(u, half_y, 1), side(u, half_y, -1)};
  }

  // Whether a sphere of radius rho around c reaches inside (the near side is the eye's plane).
  bool Reaches(const Vec& c, double rho) const {
    const Vec rel = Sub(c, eye);
    for (const Vec& n : normals) {
      if (Dot(n, rel) < -rho) return false;
    }
    return true;
  }
};

}  // namespace

void StreamView::Validate() const {
  CheckVec(eye, "eye");
  CheckVec(target, "target");
  CheckVec(up, "up");
  const Vec forward = Sub(target, eye);
  const double distance = std::sqrt(Dot(forward, forward));
  if (!(distance >= 1e-6)) {
    throw std::invalid_argument("target: at least 1e-6 m from eye (the view direction)");
  }
  const double up_norm = std::sqrt(Dot(up, up));
  if (!(std::sqrt(Dot(Cross(forward, up), Cross(forward, up))) > 1e-6 * distance * up_norm)) {
    throw std::invalid_argument("up: nonzero and not parallel to target - eye");
  }
  if (!std::isfinite(fov_y_deg) || fov_y_deg < 1 || fov_y_deg > 179) {
    throw std::invalid_argument("fov_y_deg: allowed range [1, 179] degrees");
  }
  if (!std::isfinite(aspect) || aspect < 0.05 || aspect > 20) {
    throw std::invalid_argument("aspect: allowed range [0.05, 20] (width / height)");
  }
}

ViewOrder::ViewOrder(const StreamView& view, std::span<const float> positions,
                     std::array<double, 3> lo, std::array<double, 3> hi, uint32_t stride)
    : stride_(std::max<uint32_t>(1, stride)) {
  const size_t n = positions.size() / 3;
  const size_t m = (n + stride_ - 1) / stride_;
  for (int a = 0; a < 3; ++a) {
    if (hi[a] > lo[a]) continue;
    lo[a] = std::numeric_limits<double>::infinity();
    hi[a] = -lo[a];
    for (size_t i = 0; i < n; ++i) {
      lo[a] = std::min(lo[a], double(positions[3 * i + a]));
      hi[a] = std::max(hi[a], double(positions[3 * i + a]));
    }
    if (!(hi[a] > lo[a])) lo[a] = (n ? lo[a] : 0) - 0.5, hi[a] = lo[a] + 1;
  }
  constexpr int g = kGrid;
  Vec edge;
  for (int a = 0; a < 3; ++a) edge[a] = (hi[a] - lo[a]) / g;
  cell_of_.resize(m);
  std::vector<uint32_t> count(size_t(g) * g * g, 0);
  for (size_t k = 0; k < m; ++k) {
    const float* p = &positions[3 * k * stride_];
    uint32_t cell = 0;
    for (int a = 2; a >= 0; --a) {
      const double x = std::floor((p[a] - lo[a]) / edge[a]);
      cell = cell * g + uint32_t(std::clamp(std::isfinite(x) ? x : 0.0, 0.0, double(g - 1)));
    }
    cell_of_[k] = cell;
    ++count[cell];
  }
  // Per occupied cell: in view or not, and its weight (see the header).
  const Frustum frustum(view);
  const double rho = 0.5 * std::sqrt(Dot(edge, edge));
  in_view_.assign(count.size(), 0);
  std::vector<double> weight(count.size(), 0);
  for (uint32_t cell = 0; cell < count.size(); ++cell) {
    if (count[cell] == 0) continue;
    const Vec c = {lo[0] + (cell % g + 0.5) * edge[0], lo[1] + ((cell / g) % g + 0.5) * edge[1],
                   lo[2] + (cell / (g * g) + 0.5) * edge[2]};
    const Vec rel = Sub(c, view.eye);
    const double d = std::max(std::sqrt(Dot(rel, rel)), rho);
    in_view_[cell] = frustum.Reaches(c, rho) ? 1 : 0;
    weight[cell] = (rho / d) * (rho / d) / count[cell] * (in_view_[cell] ? 1.0 : kOutsideWeight);
  }
  keys_.resize(m);
  for (size_t k = 0; k < m; ++k) {
    const double rank = double(codec::DetailRank(uint32_t(k * stride_))) * 0x1.0p-32;
    keys_[k] = float(rank / weight[cell_of_[k]]);
  }
}

std::vector<uint32_t> ViewOrder::Select(uint64_t budget) const {
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

}  // namespace dysa::service
