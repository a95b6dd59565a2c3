// The stages of probe evaluation (probe_gather.h): the plan, the CPU's gather and the finish.
#pragma once

#include <algorithm>
#include <span>
#include <vector>

#include "dysa/core/model.h"
#include "dysa/core/scene.h"
#include "dysa/core/state.h"
#include "probe_gather.h"

namespace dysa {

// What the gather must collect for `probes` at `time` (s): a window per local probe, wide enough
// to hold every particle its finish can weigh (the kernel's support around a pressure probe, the
// column's radius around a height probe, over the whole height, the support around a box where
// it stands at `time`), and the reductions the others need.
ProbeGatherPlan PlanProbeGather(std::span<const ProbeSpec> probes, const Model& model, double time);

// The gather on the CPU, over the host's particle arrays (in parallel, chunk by chunk).
void GatherProbes(const ProbeGatherPlan& plan, const ParticleArrays& particles, ProbeGather& out);

// The values of every probe (ProbeColumns() order) from a gather made with
// PlanProbeGather(probes, model); `time` (s) is the state's, for the gravity a wall pressure
// probe's hydrostatic correction uses.
std::vector<double> FinishProbes(std::span<const ProbeSpec> probes, const Model& model, double time,
                                 const ProbeGather& gather);

// A wall_pressure reading (probes.h, WallPressureAt) summed one candidate at a time: the
// Shepard sums of the pressures carried to the sensor's height, p_f + rho_f g . (x_s - x_f).
struct WallPressureSum {
  double weighted = 0;  // Pa
  double weights = 0;

  // Adds candidate `c` for a sensor at `point` with face normal `normal`, of kernel `kernel` and
  // gravity g (m/s^2, along +y): nothing when it lies behind the face or beyond the support.
  void Add(const ProbeCandidate& c, const Model& model, const PhysicalKernel<double>& kernel,
           double g, const Vec3d& point, const Vec3d& normal) {
    const Vec3d to_particle =
        model.MinimumImage(Vec3d(Vec3d(double(c.x), double(c.y), double(c.z)) - point));
    if (to_particle.dot(normal) < 0) return;
    const double w = kernel.W(to_particle.norm());
    if (w <= 0) return;
    // g . (x_s - x_f) = g (y_s - y_f): the weight of the water between the particle and the
    // sensor's height.
    weighted += (double(c.pressure) - double(c.density) * g * to_particle.y()) * w;
    weights += w;
  }
  // Pa; not negative (air does not pull on a sensor), 0 where no particle counted (dry).
  double Reading() const { return weights > 0 ? std::max(0.0, weighted / weights) : 0.0; }
};

// The reading of a wall_pressure probe at `point` with face normal `normal` from `candidates`
// (probes.h, WallPressureAt), summed in the candidates' order.
double WallPressureFrom(std::span<const ProbeCandidate> candidates, const Model& model,
                        const Vec3d& point, const Vec3d& normal, double time);

// A box_force probe (box_force_probe.cc): the box of `probe` where it stands at `time`, and the
// force from the particles of a window around it grown by the kernel's support (probes.h,
// BoxForceOn).
Aabb ProbeBoxAt(const ProbeSpec& probe, const Model& model, double time);
Vec3d BoxForceFrom(std::span<const ProbeCandidate> candidates, const Model& model, const Aabb& box,
                   double spacing, double time);

}  // namespace dysa
