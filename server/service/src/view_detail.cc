#include "dysa/service/view_detail.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

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

namespace {

// The weights of the cells holding candidates (see the header), and per cell whether it is in
// view when `in_view` is given.
void WeighCells(const StreamView& view, const ViewGrid& grid, const uint32_t* count, double* weight,
                std::vector<uint8_t>* in_view) {
  constexpr int g = ViewOrder::kGrid;
  const Vec lo = {grid.lo[0], grid.lo[1], grid.lo[2]};
  const Vec edge = {grid.edge[0], grid.edge[1], grid.edge[2]};
  const Frustum frustum(view);
  const double rho = 0.5 * std::sqrt(Dot(edge, edge));
  if (in_view) in_view->assign(kViewCells, 0);
  for (uint32_t cell = 0; cell < kViewCells; ++cell) {
    if (count[cell] == 0) continue;
    const Vec c = {lo[0] + (cell % g + 0.5) * edge[0], lo[1] + ((cell / g) % g + 0.5) * edge[1],
                   lo[2] + (cell / (g * g) + 0.5) * edge[2]};
    const Vec rel = Sub(c, view.eye);
    const double d = std::max(std::sqrt(Dot(rel, rel)), rho);
    const bool inside = frustum.Reaches(c, rho);
    if (in_view) (*in_view)[cell] = inside ? 1 : 0;
    weight[cell] = (rho / d) * (rho / d) / count[cell] * (inside ? 1.0 : ViewOrder::kOutsideWeight);
  }
}

}  // namespace

ViewSubsetRequest ViewRequest(const StreamView& view, std::array<double, 3> domain_min,
                              std::array<double, 3> domain_max, uint32_t stride,
                              std::vector<uint8_t>* in_view) {
  ViewSubsetRequest request;
  request.box_min = domain_min;
  request.box_max = domain_max;
  request.stride = std::max<uint32_t>(1, stride);
  request.weigh = [view, in_view](const ViewGrid& grid, const uint32_t* count, double* weight) {
    WeighCells(view, grid, count, weight, in_view);
  };
  return request;
}

ViewOrder::ViewOrder(const StreamView& view, std::span<const float> positions,
                     std::array<double, 3> lo, std::array<double, 3> hi, uint32_t stride)
    : keys_(positions.data(), positions.size() / 3, ViewRequest(view, lo, hi, stride, &in_view_)) {}

}  // namespace dysa::service
