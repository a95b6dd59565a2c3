// Tests of the probes' gather and finish (server/core/src/probe_gather.cc, probe_stages.h): on a
// cloud of several chunks, with a periodic axis, every probe equals a plain scan over all
// particles (the definitions of probes.h), the local ones bit for bit; the values do not depend
// on the thread count; Simulation::EvaluateProbes is the same evaluation.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "dysa/core/kernels.h"
#include "dysa/core/probes.h"
#include "dysa/core/simulation.h"
#include "probe_stages.h"
#include "solvers/physical/physical_passes.h"

namespace dysa {
namespace {

// 3.5 chunks of particles, uniformly random in the domain [0, 2] x [0, 1] x [0, 1] (periodic
// along x), with random velocities, densities and pressures.
State RandomCloud(uint32_t n) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> unit(0, 1);
  State state;
  state.particles.Resize(n);
  for (uint32_t i = 0; i < n; ++i) {
    ParticleArrays& p = state.particles;
    p.id[i] = i;
    p.position[i] = Vec3(2 * unit(rng), unit(rng), unit(rng));
    p.velocity[i] = Vec3(unit(rng) - 0.5f, unit(rng) - 0.5f, unit(rng) - 0.5f);
    p.density[i] = 1000 + 20 * unit(rng);
    p.pressure[i] = 5000 * unit(rng);
  }
  state.time = 0.3;
  return state;
}

Model PeriodicModel() {
  Scene scene;
  scene.domain = Aabb{Vec3d(0, 0, 0), Vec3d(2, 1, 1)};
  scene.periodic = {true, false, false};
  // A small box (obstacles stay a support away from a periodic axis's seam).
  scene.boxes.push_back({Aabb{Vec3d(1.82, 0.3, 0.4), Vec3d(1.89, 0.4, 0.5)}, {}});
  Params params;
  params.smoothing_radius = 0.1;
  params.particle_mass = 0.5;
  params.gravity = -9.81;
  return MakeModel(scene, params);
}

ProbeSpec Probe(ProbeKind kind, Vec3d point = Vec3d::Zero()) {
  ProbeSpec p;
  p.kind = kind;
  p.name = "probe";
  p.point = point;
  return p;
}

// Every kind, the local ones also across the periodic seam (x = 0 and x = 2 are one plane).
std::vector<ProbeSpec> AllProbes() {
  std::vector<ProbeSpec> probes;
  for (int axis = 0; axis < 3; ++axis) {
    probes.push_back(Probe(ProbeKind::kFront));
    probes.back().axis = axis;
  }
  probes.push_back(Probe(ProbeKind::kWallPressure, Vec3d(1.0, 0.0, 0.5)));
  probes.back().normal = Vec3d(0, 1, 0);
  probes.push_back(Probe(ProbeKind::kWallPressure, Vec3d(0.02, 0.5, 0.5)));  // at the seam
  probes.push_back(Probe(ProbeKind::kPressure, Vec3d(1.99, 0.4, 0.3)));
  probes.push_back(Probe(ProbeKind::kHeight, Vec3d(0.01, 0, 0.5)));
  probes.back().radius = 0.05;
  probes.back().gap = 0.2;
  probes.push_back(Probe(ProbeKind::kDensity));
  probes.push_back(Probe(ProbeKind::kKineticEnergy));
  // More count boxes than the GPU gather counts in one pass.
  for (int b = 0; b < 10; ++b) {
    probes.push_back(Probe(ProbeKind::kCountInside));
    probes.back().region = Aabb{Vec3d(0.1 * b, 0, 0), Vec3d(0.1 * b + 0.5, 0.5, 1)};
  }
  probes.push_back(Probe(ProbeKind::kBoxForce));
  probes.back().box = 0;
  probes.back().spacing = 0.013;
  return probes;
}

// The definitions of probes.h as plain loops over every particle in storage order.
std::vector<double> ScanAll(const std::vector<ProbeSpec>& probes, const Model& model,
                            const State& state) {
  const ParticleArrays& p = state.particles;
  const double support = model.kernel_support;
  const double g = physical::GravityAt(model.params, state.time);
  auto wall_pressure = [&](const Vec3d& point, const Vec3d& normal) {
    double weighted = 0, weights = 0;
    for (size_t i = 0; i < p.size(); ++i) {
      const Vec3d d = model.MinimumImage(Vec3d(p.position[i].cast<double>() - point));
      if (d.dot(normal) < 0) continue;
      const double w = CubicSpline<double>::W(d.norm(), support);
      if (w <= 0) continue;
      weighted += (double(p.pressure[i]) - double(p.density[i]) * g * d.y()) * w;
      weights += w;
    }
    return weights > 0 ? std::max(0.0, weighted / weights) : 0.0;
  };
  std::vector<double> values;
  for (const ProbeSpec& probe : probes) {
    double weighted = 0, weights = 0, sum = 0, max = 0;
    switch (probe.kind) {
      case ProbeKind::kFront: {
        double front = -std::numeric_limits<double>::infinity();
        for (const Vec3& x : p.position) front = std::max(front, double(x[probe.axis]));
        values.push_back(front);
        break;
      }
      case ProbeKind::kWallPressure:
        values.push_back(wall_pressure(probe.point, probe.normal));
        break;
      case ProbeKind::kBoxForce: {
        // Every face's patch centres, each patch's pressure times its area, outward normals.
        const Aabb& box = model.boxes.at(size_t(probe.box)).box;
        Vec3d force = Vec3d::Zero();
        for (int a = 0; a < 3; ++a) {
          const int u = (a + 1) % 3, v = (a + 2) % 3;
          const int nu = int(std::ceil((box.max[u] - box.min[u]) / probe.spacing));
          const int nv = int(std::ceil((box.max[v] - box.min[v]) / probe.spacing));
          const double du = (box.max[u] - box.min[u]) / nu, dv = (box.max[v] - box.min[v]) / nv;
          for (const double side : {-1.0, 1.0}) {
            Vec3d normal = Vec3d::Zero(), point;
            normal[a] = side;
            point[a] = side < 0 ? box.min[a] : box.max[a];
            double face = 0;
            for (int i = 0; i < nu; ++i) {
              for (int j = 0; j < nv; ++j) {
                point[u] = box.min[u] + (i + 0.5) * du;
                point[v] = box.min[v] + (j + 0.5) * dv;
                face += wall_pressure(point, normal) * (du * dv);
              }
            }
            force[a] -= side * face;
          }
        }
        values.insert(values.end(), {force.x(), force.y(), force.z()});
        break;
      }
      case ProbeKind::kPressure:
        for (size_t i = 0; i < p.size(); ++i) {
          const Vec3d d = model.MinimumImage(Vec3d(p.position[i].cast<double>() - probe.point));
          const double w = Poly6<double>::W(d.norm(), support);
          weighted += w * p.pressure[i];
          weights += w;
        }
        values.push_back(weights > 0 ? weighted / weights : 0.0);
        break;
      case ProbeKind::kHeight: {
        std::vector<double> heights;
        for (const Vec3& x : p.position) {
          const Vec3d d = model.MinimumImage(Vec3d(x.cast<double>() - probe.point));
          if (d.x() * d.x() + d.z() * d.z() <= probe.radius * probe.radius) {
            heights.push_back(double(x.y()) - model.domain.min.y());
          }
        }
        std::sort(heights.begin(), heights.end());
        double top = 0;
        for (double h : heights) {
          if (h - top > probe.gap) break;
          top = std::max(top, h);
        }
        values.push_back(top);
        break;
      }
      case ProbeKind::kDensity:
        for (Real rho : p.density) sum += rho, max = std::max(max, double(rho));
        values.push_back(sum / double(p.size()));
        values.push_back(max);
        break;
      case ProbeKind::kKineticEnergy:
        for (const Vec3& v : p.velocity) sum += v.cast<double>().squaredNorm();
        values.push_back(0.5 * model.particle_mass * sum);
        break;
      case ProbeKind::kCountInside:
        for (const Vec3& x : p.position) sum += probe.region->Contains(x.cast<double>()) ? 1 : 0;
        values.push_back(sum);
        break;
    }
  }
  return values;
}

TEST(ProbeGatherTest, EveryProbeEqualsAScanOfAllParticles) {
  const Model model = PeriodicModel();
  const State state = RandomCloud(3 * kProbeChunk + kProbeChunk / 2);
  const std::vector<ProbeSpec> probes = AllProbes();
  const std::vector<double> gathered = EvaluateProbes(probes, model, state);
  const std::vector<double> scanned = ScanAll(probes, model, state);
  ASSERT_EQ(gathered.size(), scanned.size());
  // Columns: front x, y, z; two wall pressures; pressure; height; density mean and max;
  // kinetic energy; ten counts; a box force's three.
  ASSERT_EQ(ProbeColumns(probes).size(), 23u);
  for (size_t k = 0; k < scanned.size(); ++k) {
    if (k == 7 || k == 9) {
      // The sums go chunk by chunk: the same up to rounding.
      EXPECT_NEAR(gathered[k], scanned[k], 1e-12 * std::abs(scanned[k])) << "value " << k;
    } else {
      EXPECT_EQ(gathered[k], scanned[k]) << "value " << k;
    }
  }
  // Not vacuous: the local probes found particles, the seam's on both sides of it.
  EXPECT_GT(scanned[3], 0);
  EXPECT_GT(scanned[4], 0);
  EXPECT_GT(scanned[5], 0);
  EXPECT_GT(scanned[6], 0.5);
  EXPECT_GT(std::abs(scanned[20]), 1e-6);  // the box force: the pressures differ face to face
  const ProbeGatherPlan plan = PlanProbeGather(probes, model, state.time);
  ProbeGather gather;
  GatherProbes(plan, state.particles, gather);
  ASSERT_EQ(gather.candidates.size(), 5u);
  EXPECT_GT(gather.candidates[4].size(), 100u);  // around the box
  const auto& seam = gather.candidates[1];
  EXPECT_TRUE(std::any_of(seam.begin(), seam.end(), [](auto& c) { return c.x > 1.9f; }));
  EXPECT_TRUE(std::any_of(seam.begin(), seam.end(), [](auto& c) { return c.x < 0.1f; }));
  EXPECT_TRUE(
      std::is_sorted(seam.begin(), seam.end(), [](auto& a, auto& b) { return a.index < b.index; }));
  // The windows read a small part of the cloud.
  size_t gathered_particles = 0;
  for (const auto& list : gather.candidates) gathered_particles += list.size();
  EXPECT_LT(gathered_particles, state.particles.size() / 20);
}

TEST(ProbeGatherTest, TheValuesDoNotDependOnTheThreadCount) {
  const Model model = PeriodicModel();
  const State state = RandomCloud(5 * kProbeChunk + 17);
  const std::vector<ProbeSpec> probes = AllProbes();
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const std::vector<double> one = EvaluateProbes(probes, model, state);
  omp_set_num_threads(3);
  const std::vector<double> three = EvaluateProbes(probes, model, state);
  omp_set_num_threads(threads);
  EXPECT_EQ(one, three);
}

TEST(ProbeGatherTest, NoParticlesGiveEmptyReadings) {
  const Model model = PeriodicModel();
  const State state = RandomCloud(0);
  const std::vector<double> values = EvaluateProbes(AllProbes(), model, state);
  EXPECT_TRUE(std::isnan(values[0]));
  for (size_t k = 3; k < values.size(); ++k) EXPECT_EQ(values[k], 0.0) << "value " << k;
}

TEST(ProbeGatherTest, ASimulationEvaluatesItsProbesAsTheFreeFunctionDoes) {
  Scene scene = ParseScene(R"({
    "domain": {"min": [0, 0, 0], "max": [0.6, 0.4, 0.08]},
    "fluid_blocks": [{"center": [0.1, 0.15, 0.04], "size": [0.2, 0.3, 0.08]}],
    "params": {"gravity": -9.81, "particle_spacing": 0.02, "speed_of_sound": 25},
    "probes": [{"type": "front", "name": "front", "axis": "x"},
               {"type": "wall_pressure", "name": "p", "point": [0.6, 0.02, 0.04],
                "normal": [-1, 0, 0]},
               {"type": "height", "name": "h", "point": [0.05, 0, 0.04]},
               {"type": "kinetic_energy", "name": "kinetic_energy"}],
    "solver": "wcsph"})");
  Simulation sim(scene);
  while (sim.time() < 0.1) sim.Step(0.1);
  const std::vector<double> values = sim.EvaluateProbes(scene.probes);
  EXPECT_EQ(values, EvaluateProbes(scene.probes, sim.model(), sim.state()));
  EXPECT_GT(values[0], 0.21);  // the front moved
  EXPECT_GT(values[2], 0.1);   // the column stands
  EXPECT_GT(values[3], 0);
}

}  // namespace
}  // namespace dysa
