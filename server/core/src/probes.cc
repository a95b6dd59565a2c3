#include "dysa/core/probes.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "dysa/core/kernels.h"
#include "probe_stages.h"
#include "solvers/physical/physical_passes.h"

namespace dysa {

std::vector<std::string> ProbeColumns(std::span<const ProbeSpec> probes) {
  std::vector<std::string> columns;
  for (const ProbeSpec& probe : probes) {
    if (probe.kind == ProbeKind::kDensity) {
      columns.push_back(probe.name + "_mean");
      columns.push_back(probe.name + "_max");
    } else if (probe.kind == ProbeKind::kBoxForce) {
      for (const char* axis : {"_x", "_y", "_z"}) columns.push_back(probe.name + axis);
    } else {
      columns.push_back(probe.name);
    }
  }
  return columns;
}

namespace {

bool IsLocal(ProbeKind kind) {
  return kind == ProbeKind::kHeight || kind == ProbeKind::kPressure ||
         kind == ProbeKind::kWallPressure || kind == ProbeKind::kBoxForce;
}

// A window reaching a hair beyond `reach`: the finish's own distance test decides, the window
// only has to hold every particle it could accept (W vanishes at the support's edge anyway).
constexpr double kWindowMargin = 1 + 1e-6;

ProbeWindow WindowAround(const Vec3d& point, double reach_x, double reach_y, double reach_z) {
  ProbeWindow window;
  for (int a = 0; a < 3; ++a) window.center[a] = point[a];
  window.half[0] = reach_x * kWindowMargin;
  window.half[1] = reach_y * kWindowMargin;
  window.half[2] = reach_z * kWindowMargin;
  return window;
}

// The window a box force's finish reads: the box grown by the kernel's support.
ProbeWindow WindowAroundBox(const Aabb& box, const Model& model) {
  const Vec3d reach = 0.5 * box.Size() + Vec3d::Constant(model.kernel_support);
  return WindowAround(box.Center(), reach.x(), reach.y(), reach.z());
}

double HeightRadius(const ProbeSpec& probe, const Model& model) {
  return probe.radius > 0 ? probe.radius : model.kernel_support;
}

Vec3d PositionOf(const ProbeCandidate& c) { return Vec3d(double(c.x), double(c.y), double(c.z)); }

// The connected column's top among the candidates within `radius` of `point` horizontally.
double ColumnHeight(std::span<const ProbeCandidate> candidates, const Model& model,
                    const Vec3d& point, double radius, double gap, double floor) {
  std::vector<double> heights;
  for (const ProbeCandidate& c : candidates) {
    const Vec3d d = model.MinimumImage(Vec3d(PositionOf(c) - point));
    if (d.x() * d.x() + d.z() * d.z() <= radius * radius) heights.push_back(double(c.y) - floor);
  }
  std::sort(heights.begin(), heights.end());
  double top = 0;
  for (double h : heights) {
    if (h - top > gap) break;
    top = std::max(top, h);
  }
  return top;
}

// Shepard interpolation sum_j p_j W(r_j) / sum_j W(r_j) with the poly6 kernel; 0 where no
// particle is within the smoothing radius (a point in air has no fluid pressure).
double PressureFrom(std::span<const ProbeCandidate> candidates, const Model& model,
                    const Vec3d& point) {
  const double h = model.kernel_support;
  double weighted = 0;
  double weights = 0;
  for (const ProbeCandidate& c : candidates) {
    const double r = model.MinimumImage(Vec3d(PositionOf(c) - point)).norm();
    const double w = Poly6<double>::W(r, h);
    weighted += w * c.pressure;
    weights += w;
  }
  return weights > 0 ? weighted / weights : 0.0;
}

// One local probe gathered from the host's arrays (the single-probe entry points below).
std::vector<ProbeCandidate> GatherWindow(const ParticleArrays& particles, const Model& model,
                                         const ProbeWindow& window) {
  ProbeGatherPlan plan = PlanProbeGather({}, model, 0);
  plan.windows.push_back(window);
  ProbeGather gather;
  GatherProbes(plan, particles, gather);
  return std::move(gather.candidates[0]);
}

}  // namespace

double WallPressureFrom(std::span<const ProbeCandidate> candidates, const Model& model,
                        const Vec3d& point, const Vec3d& normal, double time) {
  const PhysicalKernel<double> kernel = model.Kernel<double>();
  const double g = physical::GravityAt(model.params, time);  // along +y
  WallPressureSum sum;
  for (const ProbeCandidate& c : candidates) sum.Add(c, model, kernel, g, point, normal);
  return sum.Reading();
}

ProbeGatherPlan PlanProbeGather(std::span<const ProbeSpec> probes, const Model& model,
                                double time) {
  ProbeGatherPlan plan;
  for (int a = 0; a < 3; ++a) {
    plan.wrap.periodic[a] = model.periodic[a];
    plan.wrap.period[a] = model.domain.max[a] - model.domain.min[a];
  }
  const double support = model.kernel_support;
  const double everywhere = std::numeric_limits<double>::infinity();
  for (const ProbeSpec& probe : probes) {
    switch (probe.kind) {
      case ProbeKind::kHeight: {
        const double radius = HeightRadius(probe, model);
        plan.windows.push_back(WindowAround(probe.point, radius, everywhere, radius));
        break;
      }
      case ProbeKind::kPressure:
      case ProbeKind::kWallPressure:
        plan.windows.push_back(WindowAround(probe.point, support, support, support));
        break;
      case ProbeKind::kDensity:
        plan.density = true;
        break;
      case ProbeKind::kKineticEnergy:
        plan.kinetic_energy = true;
        break;
      case ProbeKind::kCountInside: {
        const Aabb region = probe.region.value_or(model.domain);
        ProbeBox box;
        for (int a = 0; a < 3; ++a) box.lo[a] = region.min[a], box.hi[a] = region.max[a];
        plan.count_boxes.push_back(box);
        break;
      }
      case ProbeKind::kBoxForce:
        plan.windows.push_back(WindowAroundBox(ProbeBoxAt(probe, model, time), model));
        break;
      case ProbeKind::kFront:
        break;  // the fronts are always reduced
    }
  }
  return plan;
}

std::vector<double> FinishProbes(std::span<const ProbeSpec> probes, const Model& model, double time,
                                 const ProbeGather& gather) {
  const ProbeReductions& all = gather.reductions;
  std::vector<double> values;
  size_t window = 0;
  size_t box = 0;
  for (const ProbeSpec& probe : probes) {
    std::span<const ProbeCandidate> near;
    if (IsLocal(probe.kind)) near = gather.candidates.at(window++);
    switch (probe.kind) {
      case ProbeKind::kFront:
        values.push_back(all.particles == 0 ? std::nan("") : all.front[probe.axis]);
        break;
      case ProbeKind::kHeight: {
        const double gap = probe.gap > 0 ? probe.gap : model.kernel_support;
        values.push_back(ColumnHeight(near, model, probe.point, HeightRadius(probe, model), gap,
                                      model.domain.min.y()));
        break;
      }
      case ProbeKind::kPressure:
        values.push_back(PressureFrom(near, model, probe.point));
        break;
      case ProbeKind::kWallPressure:
        values.push_back(WallPressureFrom(near, model, probe.point, probe.normal, time));
        break;
      case ProbeKind::kDensity:
        values.push_back(all.particles == 0 ? 0.0 : all.density_sum / double(all.particles));
        values.push_back(all.density_max);
        break;
      case ProbeKind::kKineticEnergy:
        values.push_back(0.5 * model.particle_mass * all.speed2_sum);
        break;
      case ProbeKind::kCountInside:
        values.push_back(all.counts.at(box++));
        break;
      case ProbeKind::kBoxForce: {
        const Vec3d force =
            BoxForceFrom(near, model, ProbeBoxAt(probe, model, time), probe.spacing, time);
        values.insert(values.end(), {force.x(), force.y(), force.z()});
        break;
      }
    }
  }
  return values;
}

double WallPressureAt(const ParticleArrays& p, const Model& model, const Vec3d& point,
                      const Vec3d& normal, double time) {
  const double s = model.kernel_support;
  return WallPressureFrom(GatherWindow(p, model, WindowAround(point, s, s, s)), model, point,
                          normal, time);
}

double ConnectedColumnHeight(const ParticleArrays& particles, const Model& model,
                             const Vec3d& point, double radius, double gap, double floor) {
  const double everywhere = std::numeric_limits<double>::infinity();
  const ProbeWindow window = WindowAround(point, radius, everywhere, radius);
  return ColumnHeight(GatherWindow(particles, model, window), model, point, radius, gap, floor);
}

Vec3d BoxForceOn(const ParticleArrays& particles, const Model& model, int box, double spacing,
                 double time) {
  ProbeSpec probe;
  probe.kind = ProbeKind::kBoxForce;
  probe.box = box;
  probe.spacing = spacing;
  const Aabb where = ProbeBoxAt(probe, model, time);
  return BoxForceFrom(GatherWindow(particles, model, WindowAroundBox(where, model)), model, where,
                      spacing, time);
}

std::vector<double> EvaluateProbes(std::span<const ProbeSpec> probes, const Model& model,
                                   const State& state) {
  ProbeGather gather;
  GatherProbes(PlanProbeGather(probes, model, state.time), state.particles, gather);
  return FinishProbes(probes, model, state.time, gather);
}

}  // namespace dysa
