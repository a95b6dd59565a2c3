// Tests of the probes' gather on the GPU (server/core/src/cuda/probe_gatherer.cu) through
// Simulation::EvaluateProbes: for every solver with a GPU backend, the values the device gathers
// equal those of the host's scan of the downloaded state (the local probes and the extremes and
// counts bit for bit, the sums to rounding), with a window holding more particles than the
// gather's first buffer and more count boxes than one pass counts. ctest label `gpu`: skips,
// printing why, where no CUDA GPU can run.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "dysa/core/probes.h"
#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "support/gpu_test.h"

namespace dysa {
namespace {

using dysa::testing::kGpu;

ProbeSpec Probe(ProbeKind kind, const std::string& name, Vec3d point = Vec3d::Zero()) {
  ProbeSpec p;
  p.kind = kind;
  p.name = name;
  p.point = point;
  return p;
}

// A block of water falling or breaking in its box, with every kind of probe placed from the
// box and the block: seed_basic's cube (30^3 = 27,000 particles) for the seed; for the physical
// solvers a dam of 40 x 30 x 20 particles (24,000) with a box obstacle against its face and
// that box's force. The wide height probe holds thousands of particles, more than the gather's
// first buffer.
Scene ProbedScene(const std::string& solver) {
  Scene scene = solver == "seed" ? LoadScene("seed_basic") : ParseScene(R"({
    "domain": {"min": [0, 0, 0], "max": [0.8, 0.5, 0.2]},
    "fluid_blocks": [{"center": [0.2, 0.15, 0.1], "size": [0.4, 0.3, 0.2]}],
    "obstacles": [{"type": "box", "center": [0.43, 0.05, 0.1], "size": [0.05, 0.1, 0.1]}],
    "params": {"gravity": -9.81, "particle_spacing": 0.01, "speed_of_sound": 25},
    "solver": ")" + solver + R"("})");
  const Aabb box = scene.domain;
  const Vec3d size = box.Size();
  const Vec3d block = scene.fluid_blocks.at(0).center.value_or(box.Center());
  std::vector<ProbeSpec>& probes = scene.probes;
  probes.clear();
  probes.push_back(Probe(ProbeKind::kFront, "front_x"));
  probes.push_back(Probe(ProbeKind::kFront, "front_y"));
  probes.back().axis = 1;
  probes.push_back(
      Probe(ProbeKind::kWallPressure, "p_floor", Vec3d(block.x(), box.min.y(), block.z())));
  probes.back().normal = Vec3d(0, 1, 0);
  probes.push_back(Probe(ProbeKind::kWallPressure, "p_wall",
                         Vec3d(box.min.x(), box.min.y() + 0.1 * size.y(), block.z())));
  probes.back().normal = Vec3d(1, 0, 0);
  probes.push_back(Probe(ProbeKind::kPressure, "p_inside", block));
  probes.push_back(Probe(ProbeKind::kHeight, "h_wide", block));
  probes.back().radius = 0.2 * size.x();
  probes.push_back(Probe(ProbeKind::kHeight, "h_gauge", block));
  probes.push_back(Probe(ProbeKind::kDensity, "rho"));
  probes.push_back(Probe(ProbeKind::kKineticEnergy, "ke"));
  // Ten slices across x: more count boxes than one pass of the gather counts.
  for (int b = 0; b < 10; ++b) {
    // Appended, not "n" + to_string: GCC 12 warns falsely (-Wrestrict) on that insert.
    std::string name = "n";
    name += std::to_string(b);
    probes.push_back(Probe(ProbeKind::kCountInside, name));
    Aabb slice = box;
    slice.min.x() = box.min.x() + 0.1 * b * size.x();
    slice.max.x() = slice.min.x() + 0.1 * size.x();
    probes.back().region = slice;
  }
  // The physical solvers' box stands against the dam's face: its force is the dam's push.
  if (!scene.boxes.empty()) {
    probes.push_back(Probe(ProbeKind::kBoxForce, "F"));
    probes.back().box = 0;
  }
  return scene;
}

class ProbeGathererTest : public ::testing::TestWithParam<std::string> {};

TEST_P(ProbeGathererTest, TheDeviceGatherEqualsTheHostScan) {
  const Scene scene = ProbedScene(GetParam());
  SKIP_WITHOUT_GPU();
  Simulation sim(scene, kGpu);
  // The seed's cube falls from the middle of a 6 m box and reaches the floor after 0.45 s (on
  // the CPU its floor probe reads 20 kPa at 0.6 s); the physical solvers' dam stands on it.
  const int frames = GetParam() == "seed" ? 36 : 6;
  for (int frame = 0; frame < frames; ++frame) sim.StepFrame();
  ASSERT_EQ(sim.alarm(), "");
  // The device first: state() would refresh the host copy, which the host scan then reads.
  const std::vector<double> device = sim.EvaluateProbes(scene.probes);
  const std::vector<double> host = EvaluateProbes(scene.probes, sim.model(), sim.state());
  const std::vector<std::string> columns = ProbeColumns(scene.probes);
  ASSERT_EQ(device.size(), host.size());
  for (size_t k = 0; k < host.size(); ++k) {
    if (columns[k] == "rho_mean" || columns[k] == "ke") {
      EXPECT_NEAR(device[k], host[k], 1e-12 * std::abs(host[k])) << columns[k];
    } else {
      EXPECT_EQ(device[k], host[k]) << columns[k];
    }
  }
  // The probes read something: the water is there and moving.
  EXPECT_GT(host[2], 100) << "p_floor";
  EXPECT_GT(host[5], 0) << "h_wide";
  EXPECT_GT(host[9], 0) << "ke";
  double counted = 0;
  for (size_t k = 10; k < 20; ++k) counted += host[k];
  EXPECT_GT(counted, 20000) << "the slices hold the particles";
  if (GetParam() != "seed") {
    ASSERT_EQ(columns.at(20), "F_x");
    EXPECT_GT(host[20], 1.0) << "the dam pushes its box towards +x";
  }
}

INSTANTIATE_TEST_SUITE_P(EverySolver, ProbeGathererTest,
                         ::testing::Values("seed", "wcsph", "dfsph"),
                         [](const auto& p) { return p.param; });

}  // namespace
}  // namespace dysa
