// What the GPU tests share: the device, the skip where no CUDA GPU can run (printing why), the
// physical solvers' test scenes, and the CPU-GPU agreement check.
#pragma once

#include <gtest/gtest.h>

#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "dysa/core/device.h"
#include "dysa/core/probes.h"
#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"

namespace dysa::testing {

inline const Device kGpu{Device::Kind::kCuda, 0};

// Skips the test, printing why, where cuda:0 cannot run.
#define SKIP_WITHOUT_GPU()                                                             \
  do {                                                                                 \
    const std::string reason = ::dysa::DeviceUnavailableReason(::dysa::testing::kGpu); \
    if (!reason.empty()) GTEST_SKIP() << "no CUDA GPU to test on: " << reason;         \
  } while (0)

// A dam of 10 x 15 x 4 particles breaking past a sphere and a box, with a no-slip floor, for the
// physical solver `solver`.
inline Scene DamScene(const std::string& solver) {
  // The solver is part of the text: parsing checks the scene against it (a physical solver's
  // kernel support, for instance).
  return ParseScene(R"({
    "domain": {"min": [0, 0, 0], "max": [0.6, 0.4, 0.08], "no_slip": [false, true, false]},
    "fluid_blocks": [{"center": [0.1, 0.15, 0.04], "size": [0.2, 0.3, 0.08]}],
    "obstacles": [{"type": "sphere", "center": [0.33, 0.0, 0.04], "radius": 0.07},
                  {"type": "box", "center": [0.5, 0.04, 0.04], "size": [0.04, 0.08, 0.3]}],
    "params": {"gravity": -9.81, "particle_spacing": 0.02, "speed_of_sound": 25,
               "kinematic_viscosity": 1e-5},
    "probes": [{"type": "front", "name": "front", "axis": "x"},
               {"type": "pressure", "name": "p_floor", "point": [0.1, 0.02, 0.04]},
               {"type": "kinetic_energy", "name": "kinetic_energy"}],
    "solver": ")" + solver +
                    R"("})");
}

// DamScene with DualSPHysics's kernel: Wendland C2 at h = 1.732 d (support 3.46 d, four wall
// layers).
inline Scene WendlandDamScene(const std::string& solver) {
  Scene scene = DamScene(solver);
  SetParam(scene.params, "kernel", 1);
  SetParam(scene.params, "smoothing_length_ratio", 1.732);
  return scene;
}

// DamScene with both obstacles moving: the box slides into the dam at 0.3 m/s over
// [0.05, 0.25] s and the sphere rises and comes back down along a keyframed path, so the
// boundary is moved and sorted again each step, its samples carry velocities and the contact
// meets surfaces closing in.
inline Scene MovingDamScene(const std::string& solver) {
  Scene scene = DamScene(solver);
  scene.boxes.at(0).motion.keys = {{0.05, Vec3d::Zero()}, {0.25, Vec3d(-0.06, 0, 0)}};
  scene.spheres.at(0).motion.keys = {
      {0, Vec3d::Zero()}, {0.1, Vec3d(0, 0.03, 0)}, {0.2, Vec3d(0.01, 0, 0)}};
  return scene;
}

// A periodic channel across x and z, driven by gravity along -y: the periodic grid.
inline Scene PeriodicScene(const std::string& solver) {
  return ParseScene(R"({
    "domain": {"min": [0, 0, 0], "max": [0.2, 0.3, 0.12], "periodic": [true, false, true]},
    "fluid_blocks": [{"center": [0.1, 0.1, 0.06], "size": [0.2, 0.2, 0.12],
                      "velocity": [0.3, 0, -0.2]}],
    "params": {"gravity": -9.81, "particle_spacing": 0.02, "speed_of_sound": 25},
    "solver": ")" + solver +
                    R"("})");
}

// Two blocks of water thrown apart at 8 m/s each, each towards a wall, with c0 = 4 m/s: where
// they touch, the continuity equation drives the density down, and at the walls up, beyond
// what any weakly compressible flow reaches (wcsph holds its carried density in
// [0.7, 1.3] rho0: carried_density_min, kCarriedDensityMax).
inline Scene SplittingBlocksScene(const std::string& solver) {
  return ParseScene(R"({
    "domain": {"min": [0, 0, 0], "max": [0.4, 0.2, 0.08]},
    "fluid_blocks": [{"center": [0.14, 0.06, 0.04], "size": [0.08, 0.12, 0.08],
                      "velocity": [-8, 0, 0]},
                     {"center": [0.26, 0.06, 0.04], "size": [0.08, 0.12, 0.08],
                      "velocity": [8, 0, 0]}],
    "params": {"gravity": -9.81, "particle_spacing": 0.02, "speed_of_sound": 4},
    "solver": ")" + solver +
                    R"("})");
}

struct Summary {
  double kinetic_energy = 0;     // J
  double mean_density = 0;       // kg/m^3
  Vec3d centre = Vec3d::Zero();  // m
  double time = 0;
  uint64_t steps = 0;
  uint64_t hash = 0;
  std::vector<double> probes;
};

inline Summary RunFor(const Scene& scene, const Device& device, double seconds) {
  Simulation sim(scene, device);
  while (sim.time() < seconds && sim.alarm().empty()) sim.StepFrame();
  EXPECT_EQ(sim.alarm(), "");
  const State& state = sim.state();
  const ParticleArrays& p = state.particles;
  Summary s;
  for (size_t i = 0; i < p.size(); ++i) {
    s.kinetic_energy +=
        0.5 * sim.model().particle_mass * p.velocity[i].cast<double>().squaredNorm();
    s.mean_density += p.density[i];
    s.centre += p.position[i].cast<double>();
  }
  s.mean_density /= double(p.size());
  s.centre /= double(p.size());
  s.time = sim.time();
  s.steps = sim.step();
  s.hash = StateHash(state);
  s.probes = EvaluateProbes(scene.probes, sim.model(), state);
  return s;
}

// The tolerances the CPU and the GPU agree within after `seconds` of a physical solver's run
// (hundreds of adaptive steps), whatever the last bit of a pow() (wcsph) or the order of a
// solve's error sum (dfsph): kinetic energy 3%, mean density 0.1%, centre of mass 2 mm, the
// number of steps 2%, probes 3%.
inline void ExpectAgreement(const Scene& scene, double seconds) {
  const Summary cpu = RunFor(scene, Device{}, seconds);
  const Summary gpu = RunFor(scene, kGpu, seconds);
  std::printf("CPU: %" PRIu64 " steps, hash %016" PRIx64 "; GPU: %" PRIu64
              " steps, hash %016" PRIx64 "%s\n",
              cpu.steps, cpu.hash, gpu.steps, gpu.hash,
              cpu.hash == gpu.hash ? " (bit-identical)" : "");
  EXPECT_DOUBLE_EQ(gpu.time, cpu.time);
  EXPECT_NEAR(double(gpu.steps), double(cpu.steps), 0.02 * double(cpu.steps) + 2);
  EXPECT_NEAR(gpu.kinetic_energy, cpu.kinetic_energy, 0.03 * cpu.kinetic_energy + 1e-9);
  EXPECT_NEAR(gpu.mean_density, cpu.mean_density, 1e-3 * cpu.mean_density);
  EXPECT_LT((gpu.centre - cpu.centre).norm(), 2e-3)
      << "centre of mass, m: GPU " << gpu.centre.transpose() << ", CPU " << cpu.centre.transpose();
  ASSERT_EQ(gpu.probes.size(), cpu.probes.size());
  for (size_t k = 0; k < cpu.probes.size(); ++k) {
    EXPECT_NEAR(gpu.probes[k], cpu.probes[k], 0.03 * std::abs(cpu.probes[k]) + 1e-6)
        << scene.probes[k].name;
  }
}

}  // namespace dysa::testing
