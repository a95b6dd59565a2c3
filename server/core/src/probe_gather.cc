// The probes' gather on the CPU (probe_gather.h).
#include <algorithm>
#include <cstdint>

#include "probe_stages.h"

namespace dysa {

namespace {

// The gather of particles [begin, end): reductions and window hits in storage order.
void GatherChunk(const ProbeGatherPlan& plan, const ParticleArrays& p, size_t begin, size_t end,
                 ProbeGather& out) {
  ProbeReductions& r = out.reductions;
  r.counts.assign(plan.count_boxes.size(), 0.0);
  out.candidates.assign(plan.windows.size(), {});
  const bool has_density = p.density.size() >= end;
  const bool has_pressure = p.pressure.size() >= end;
  const bool has_velocity = p.velocity.size() >= end;
  for (size_t i = begin; i < end; ++i) {
    const Vec3& x = p.position[i];
    for (int a = 0; a < 3; ++a) r.front[a] = std::max(r.front[a], double(x[a]));
    if (plan.density && has_density) {
      r.density_sum += p.density[i];
      r.density_max = std::max(r.density_max, double(p.density[i]));
    }
    if (plan.kinetic_energy && has_velocity) {
      r.speed2_sum += p.velocity[i].cast<double>().squaredNorm();
    }
    for (size_t b = 0; b < plan.count_boxes.size(); ++b) {
      const ProbeBox& box = plan.count_boxes[b];
      bool inside = true;
      for (int a = 0; a < 3; ++a) inside = inside && x[a] >= box.lo[a] && x[a] <= box.hi[a];
      r.counts[b] += inside ? 1 : 0;
    }
    for (size_t w = 0; w < plan.windows.size(); ++w) {
      if (!InProbeWindow(plan.wrap, plan.windows[w], x.data())) continue;
      out.candidates[w].push_back({uint32_t(i), x.x(), x.y(), x.z(),
                                   has_pressure ? p.pressure[i] : 0.0f,
                                   has_density ? p.density[i] : 0.0f});
    }
  }
}

}  // namespace

void GatherProbes(const ProbeGatherPlan& plan, const ParticleArrays& particles, ProbeGather& out) {
  const size_t n = particles.position.size();
  const int64_t chunks = int64_t((n + kProbeChunk - 1) / kProbeChunk);
  std::vector<ProbeGather> parts(size_t(std::max<int64_t>(chunks, 1)));
#pragma omp parallel for schedule(static) if (chunks > 1)
  for (int64_t c = 0; c < chunks; ++c) {
    GatherChunk(plan, particles, size_t(c) * kProbeChunk, std::min(n, size_t(c + 1) * kProbeChunk),
                parts[size_t(c)]);
  }
  if (chunks == 0) GatherChunk(plan, particles, 0, 0, parts[0]);
  // The chunks in order: the sums' order, and the candidates' ascending storage order.
  out.reductions = ProbeReductions{};
  out.reductions.particles = particles.size();
  out.reductions.counts.assign(plan.count_boxes.size(), 0.0);
  out.candidates.assign(plan.windows.size(), {});
  for (const ProbeGather& part : parts) {
    const ProbeReductions& r = part.reductions;
    ProbeReductions& total = out.reductions;
    for (int a = 0; a < 3; ++a) total.front[a] = std::max(total.front[a], r.front[a]);
    total.density_sum += r.density_sum;
    total.density_max = std::max(total.density_max, r.density_max);
    total.speed2_sum += r.speed2_sum;
    for (size_t b = 0; b < r.counts.size(); ++b) total.counts[b] += r.counts[b];
    for (size_t w = 0; w < part.candidates.size(); ++w) {
      out.candidates[w].insert(out.candidates[w].end(), part.candidates[w].begin(),
                               part.candidates[w].end());
    }
  }
}

}  // namespace dysa
