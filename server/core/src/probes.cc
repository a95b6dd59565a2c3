#include "dysa/core/probes.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "dysa/core/kernels.h"
#include "solvers/physical/physical_passes.h"

namespace dysa {

std::vector<std::string> ProbeColumns(std::span<const ProbeSpec> probes) {
  std::vector<std::string> columns;
  for (const ProbeSpec& probe : probes) {
    if (probe.kind == ProbeKind::kDensity) {
      columns.push_back(probe.name + "_mean");
      columns.push_back(probe.name + "_max");
    } else {
      columns.push_back(probe.name);
    }
  }
  return columns;
}

namespace {

// Probes run once per output, not per step: plain serial loops, summed in a fixed order so the
// CSV is identical for any thread count.
double Front(const ParticleArrays& p, int axis) {
  double front = -std::numeric_limits<double>::infinity();
  for (const Vec3& x : p.position) front = std::max(front, double(x[axis]));
  return p.size() == 0 ? std::nan("") : front;
}

double Height(const ParticleArrays& p, const Model& model, const ProbeSpec& probe) {
  const double radius = probe.radius > 0 ? probe.radius : model.kernel_support;
  const double gap = probe.gap > 0 ? probe.gap : model.kernel_support;
  return ConnectedColumnHeight(p, model, probe.point, radius, gap, model.domain.min.y());
}

// Shepard interpolation sum_j p_j W(r_j) / sum_j W(r_j) with the poly6 kernel; 0 where no
// particle is within the smoothing radius (a point in air has no fluid pressure).
double PressureAt(const ParticleArrays& p, const Model& model, const Vec3d& point) {
  const double h = model.kernel_support;
  double weighted = 0;
  double weights = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    const double r = model.MinimumImage(Vec3d(p.position[i].cast<double>() - point)).norm();
    const double w = Poly6<double>::W(r, h);
    weighted += w * p.pressure[i];
    weights += w;
  }
  return weights > 0 ? weighted / weights : 0.0;
}

}  // namespace

double WallPressureAt(const ParticleArrays& p, const Model& model, const Vec3d& point,
                      const Vec3d& normal, double time) {
  const double support = model.kernel_support;
  const double g = physical::GravityAt(model.params, time);  // along +y
  double weighted = 0;
  double weights = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    const Vec3d to_particle = model.MinimumImage(Vec3d(p.position[i].cast<double>() - point));
    if (to_particle.dot(normal) < 0) continue;
    const double w = CubicSpline<double>::W(to_particle.norm(), support);
    if (w <= 0) continue;
    // g . (x_s - x_f) = g (y_s - y_f): the weight of the water between the particle and the
    // sensor's height.
    weighted += (double(p.pressure[i]) - double(p.density[i]) * g * to_particle.y()) * w;
    weights += w;
  }
  return weights > 0 ? std::max(0.0, weighted / weights) : 0.0;
}

double ConnectedColumnHeight(const ParticleArrays& particles, const Model& model,
                             const Vec3d& point, double radius, double gap, double floor) {
  std::vector<double> heights;
  for (const Vec3& x : particles.position) {
    const Vec3d d = model.MinimumImage(Vec3d(x.cast<double>() - point));
    if (d.x() * d.x() + d.z() * d.z() <= radius * radius) heights.push_back(double(x.y()) - floor);
  }
  std::sort(heights.begin(), heights.end());
  double top = 0;
  for (double h : heights) {
    if (h - top > gap) break;
    top = std::max(top, h);
  }
  return top;
}

std::vector<double> EvaluateProbes(std::span<const ProbeSpec> probes, const Model& model,
                                   const State& state) {
  const ParticleArrays& p = state.particles;
  std::vector<double> values;
  for (const ProbeSpec& probe : probes) {
    switch (probe.kind) {
      case ProbeKind::kFront:
        values.push_back(Front(p, probe.axis));
        break;
      case ProbeKind::kHeight:
        values.push_back(Height(p, model, probe));
        break;
      case ProbeKind::kPressure:
        values.push_back(PressureAt(p, model, probe.point));
        break;
      case ProbeKind::kWallPressure:
        values.push_back(WallPressureAt(p, model, probe.point, probe.normal, state.time));
        break;
      case ProbeKind::kDensity: {
        double sum = 0;
        double max = 0;
        for (Real rho : p.density) sum += rho, max = std::max(max, double(rho));
        values.push_back(p.size() == 0 ? 0.0 : sum / double(p.size()));
        values.push_back(max);
        break;
      }
      case ProbeKind::kKineticEnergy: {
        double sum = 0;
        for (const Vec3& v : p.velocity) sum += v.cast<double>().squaredNorm();
        values.push_back(0.5 * model.particle_mass * sum);
        break;
      }
      case ProbeKind::kCountInside: {
        const Aabb region = probe.region.value_or(model.domain);
        double count = 0;
        for (const Vec3& x : p.position) count += region.Contains(x.cast<double>()) ? 1 : 0;
        values.push_back(count);
        break;
      }
    }
  }
  return values;
}

}  // namespace dysa
