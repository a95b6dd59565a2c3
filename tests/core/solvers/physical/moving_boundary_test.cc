// Obstacles with a prescribed motion (ObstacleMotion, scenes/README.md "Motion") in every
// solver: a zero motion steps exactly as no motion, a box pushed through still water drives it
// along, a plate lifted under water lifts it, and no particle ends a step inside a moving
// obstacle.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "dysa/core/device.h"
#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"

namespace dysa {
namespace {

class MovingBoundaryTest : public ::testing::TestWithParam<std::string> {
 public:
  bool physical() const { return GetParam() != "seed"; }
  // The solver's parameters at d = 0.02 m (the seed model at its own smoothing radius).
  std::string Params() const {
    return physical() ? R"({"gravity": -9.81, "particle_spacing": 0.02, "speed_of_sound": 10})"
                      : R"({"gravity": -9.81, "smoothing_radius": 0.04, "particle_mass": 0.008,
                          "target_density": 1000, "pressure_multiplier": 200,
                          "near_pressure_multiplier": 2, "time_scale": 1,
                          "iterations_per_frame": 10, "collision_damping": 0.5})";
  }
  std::string Block(const std::string& center, const std::string& size) const {
    return R"({"center": )" + center + R"(, "size": )" + size +
           (physical() ? "" : R"(, "spacing": 0.02)") + "}";
  }
};

// A tank with a layer of still water 0.12 m deep and a box standing in it across the tank's
// width, with the given motion (JSON, or empty for none).
Scene PushScene(const MovingBoundaryTest& t, const std::string& motion) {
  return ParseScene(R"({"domain": {"min": [0, 0, 0], "max": [0.8, 0.3, 0.06]},
      "fluid_blocks": [)" +
                    t.Block("[0.4, 0.06, 0.03]", "[0.8, 0.12, 0.06]") + R"(],
      "obstacles": [{"type": "box", "center": [0.2, 0.1, 0.03], "size": [0.06, 0.2, 0.2])" +
                    (motion.empty() ? "" : R"(, "motion": )" + motion) + R"(}],
      "solver": ")" +
                    t.GetParam() + R"(", "params": )" + t.Params() + "}");
}

bool SameState(const State& a, const State& b) {
  if (a.particles.size() != b.particles.size()) return false;
  for (size_t i = 0; i < a.particles.size(); ++i) {
    if (a.particles.id[i] != b.particles.id[i] ||
        a.particles.position[i] != b.particles.position[i] ||
        a.particles.velocity[i] != b.particles.velocity[i]) {
      return false;
    }
  }
  return a.time == b.time;
}

// A motion that stays put runs every moving-boundary code path (the physical solvers' boundary
// is moved and sorted again each step, its samples carry a velocity of 0): bit for bit what the
// static obstacle gives.
TEST_P(MovingBoundaryTest, ZeroMotionStepsExactlyAsNoMotion) {
  Simulation still(PushScene(*this, ""));
  Simulation zero(PushScene(*this, R"({"velocity": [0, 0, 0]})"));
  if (physical()) {
    EXPECT_EQ(zero.PassNames().front(), "move_boundary");
    EXPECT_NE(still.PassNames().front(), "move_boundary");  // a static scene pays nothing
  }
  for (int step = 0; step < 30; ++step) {
    still.Step();
    zero.Step();
  }
  EXPECT_TRUE(SameState(still.state(), zero.state()));
}

double MomentumX(const Simulation& sim) {
  double sum = 0;
  for (const Vec3& v : sim.state().particles.velocity) sum += v.x();
  return sum * sim.model().particle_mass;
}

// How many particles lie inside `box` moved by `offset`, shrunk by `margin` on every face.
int CountInside(const Simulation& sim, const Aabb& box, const Vec3d& offset, double margin) {
  int inside = 0;
  const Aabb moved{box.min + offset + Vec3d::Constant(margin),
                   box.max + offset - Vec3d::Constant(margin)};
  for (const Vec3& x : sim.state().particles.position) inside += moved.Contains(x.cast<double>());
  return inside;
}

// The box moves at 0.5 m/s along x through the water for 0.2 s: the water it pushes gains
// momentum along x, which a static box does not give it; and the box never holds a particle.
class PhysicalMovingBoundaryTest : public MovingBoundaryTest {};

TEST_P(PhysicalMovingBoundaryTest, APushedBoxDrivesTheWaterAlong) {
  Simulation still(PushScene(*this, ""));
  Simulation pushed(PushScene(*this, R"({"velocity": [0.5, 0, 0], "start": 0.02})"));
  const Aabb box = pushed.scene().boxes[0].box;
  const ObstacleMotion& motion = pushed.scene().boxes[0].motion;
  int worst = 0;
  while (pushed.state().time < 0.22) {
    pushed.Step();
    ASSERT_TRUE(pushed.alarm().empty()) << pushed.alarm();
    // Strictly inside, by a hundredth of a spacing: the contact keeps the fluid r0 / 2 out.
    worst =
        std::max(worst, CountInside(pushed, box, motion.DisplacementAt(pushed.state().time), 2e-4));
  }
  while (still.state().time < 0.22) still.Step();
  EXPECT_EQ(worst, 0);
  // The box sweeps 0.1 m of a 0.12 m deep layer 0.06 m wide: about 0.72 kg at 0.5 m/s were it
  // all carried along, 0.36 kg m/s. At least a quarter of that is in the water.
  const double carried = 1000 * 0.1 * 0.12 * 0.06 * 0.5;
  // (The static box's water sloshes too, from its start around the box: the difference counts.)
  EXPECT_GT(MomentumX(pushed) - MomentumX(still), 0.25 * carried)
      << "pushed: " << MomentumX(pushed) << ", static: " << MomentumX(still);
}

// A plate across the whole tank, under a layer of water, is lifted 0.1 m at 0.5 m/s: the water
// resting on it cannot flow around it and rises with it, its centre of mass by about 0.1 m, and
// no particle is left below the plate's top.
TEST_P(PhysicalMovingBoundaryTest, ALiftedPlateLiftsTheWaterOnIt) {
  Simulation sim(ParseScene(R"({"domain": {"min": [0, 0, 0], "max": [0.16, 0.4, 0.06]},
      "fluid_blocks": [)" + Block("[0.08, 0.1, 0.03]", "[0.16, 0.1, 0.06]") +
                            R"(],
      "obstacles": [{"type": "box", "center": [0.08, 0.025, 0.03], "size": [0.2, 0.05, 0.2],
                     "motion": {"velocity": [0, 0.5, 0], "start": 0.05, "end": 0.25}}],
      "solver": ")" + GetParam() +
                            R"(", "params": )" + Params() + "}"));
  auto mean_height = [&] {
    double sum = 0;
    for (const Vec3& x : sim.state().particles.position) sum += x.y();
    return sum / double(sim.state().particles.size());
  };
  while (sim.state().time < 0.05) sim.Step();
  const double before = mean_height();
  double lowest = 1;
  while (sim.state().time < 0.35) {
    sim.Step();
    ASSERT_TRUE(sim.alarm().empty()) << sim.alarm();
    if (sim.state().time > 0.25) {
      for (const Vec3& x : sim.state().particles.position) lowest = std::min(lowest, double(x.y()));
    }
  }
  EXPECT_NEAR(mean_height() - before, 0.1, 0.02);
  EXPECT_GT(lowest, 0.15 - 1e-3);  // the plate's top, lifted
}

// On a GPU: tests/core/cuda/*_pipeline_test.cc (MovingObstacles tests, ctest label gpu).

INSTANTIATE_TEST_SUITE_P(Solvers, MovingBoundaryTest, ::testing::Values("seed", "wcsph", "dfsph"),
                         [](const auto& p) { return p.param; });
INSTANTIATE_TEST_SUITE_P(Solvers, PhysicalMovingBoundaryTest, ::testing::Values("wcsph", "dfsph"),
                         [](const auto& p) { return p.param; });

// The seed model's collision reflects the velocity relative to the obstacle: particles at rest,
// too far apart to feel each other, are struck by a box moving at 1 m/s and leave ahead of it
// at 1 + collision_damping m/s (a static box would leave them at rest), never inside it.
TEST(SeedMovingObstacleTest, ParticlesStruckByAMovingBoxLeaveAheadOfIt) {
  Simulation sim(ParseScene(R"({"domain": {"min": [-2, -2, -2], "max": [4, 2, 2]},
      "fluid_blocks": [{"center": [0.5, 0, 0], "size": [0.3, 0.9, 0.9], "spacing": 0.3}],
      "obstacles": [{"type": "box", "center": [-1, 0, 0], "size": [0.2, 2, 2],
                     "motion": {"velocity": [1, 0, 0]}}],
      "solver": "seed",
      "params": {"gravity": 0, "smoothing_radius": 0.2, "viscosity": 0,
                 "collision_damping": 0.5, "time_scale": 1, "iterations_per_frame": 10}})"));
  ASSERT_EQ(sim.state().particles.size(), 9u);
  const ObstacleMotion& motion = sim.scene().boxes[0].motion;
  const Aabb box = sim.scene().boxes[0].box;
  while (sim.state().time < 2.0) {
    sim.Step();
    EXPECT_EQ(CountInside(sim, box, motion.DisplacementAt(sim.state().time), 1e-4), 0)
        << "t = " << sim.state().time;
  }
  for (const Vec3& v : sim.state().particles.velocity) EXPECT_NEAR(v.x(), 1.5, 1e-4);
}

}  // namespace
}  // namespace dysa
