// Tests of dysa/core/probes.h on small hand-built states with hand-computed expected values.
#include "dysa/core/probes.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "dysa/core/kernels.h"
#include "dysa/core/model.h"

namespace dysa {
namespace {

// A state with the given positions and velocities (ids 0..n-1), densities and pressures 0.
State MakeState(const std::vector<Vec3>& positions, const std::vector<Vec3>& velocities = {}) {
  State state;
  state.particles.Resize(positions.size());
  for (size_t i = 0; i < positions.size(); ++i) {
    state.particles.id[i] = uint32_t(i);
    state.particles.position[i] = positions[i];
    state.particles.velocity[i] = velocities.empty() ? Vec3::Zero() : velocities[i];
    state.particles.density[i] = 0;
    state.particles.pressure[i] = 0;
  }
  return state;
}

// Domain [0, 4] x [-1, 3] x [0, 4], smoothing radius 0.5, particle mass 2.
Model TestModel() {
  Scene scene;
  scene.domain = Aabb{Vec3d(0, -1, 0), Vec3d(4, 3, 4)};
  Params params;
  params.smoothing_radius = 0.5;
  params.particle_mass = 2.0;
  return MakeModel(scene, params);
}

ProbeSpec Probe(ProbeKind kind, std::string name) {
  ProbeSpec p;
  p.kind = kind;
  p.name = std::move(name);
  return p;
}

double Evaluate1(const ProbeSpec& probe, const Model& model, const State& state) {
  const std::vector<double> values = EvaluateProbes(std::span(&probe, 1), model, state);
  EXPECT_EQ(values.size(), 1u);
  return values.empty() ? std::nan("") : values[0];
}

TEST(ProbeColumnsTest, DensityExpandsIntoMeanAndMax) {
  std::vector<ProbeSpec> probes = {
      Probe(ProbeKind::kKineticEnergy, "ke"), Probe(ProbeKind::kDensity, "rho"),
      Probe(ProbeKind::kFront, "front_x"), Probe(ProbeKind::kDensity, "d2")};
  EXPECT_EQ(ProbeColumns(probes), (std::vector<std::string>{"ke", "rho_mean", "rho_max", "front_x",
                                                            "d2_mean", "d2_max"}));
  EXPECT_TRUE(ProbeColumns({}).empty());

  const Model model = TestModel();
  State state = MakeState({Vec3(1, 1, 1)});
  EXPECT_EQ(EvaluateProbes(probes, model, state).size(), ProbeColumns(probes).size());
}

TEST(ProbesTest, FrontAlongEachAxis) {
  const Model model = TestModel();
  const State state =
      MakeState({Vec3(0.5f, 2.0f, 1.0f), Vec3(3.25f, -0.5f, 0.75f), Vec3(1.0f, 0.0f, 3.5f)});
  ProbeSpec probe = Probe(ProbeKind::kFront, "front");
  probe.axis = 0;
  EXPECT_EQ(Evaluate1(probe, model, state), 3.25);
  probe.axis = 1;
  EXPECT_EQ(Evaluate1(probe, model, state), 2.0);
  probe.axis = 2;
  EXPECT_EQ(Evaluate1(probe, model, state), 3.5);
}

TEST(ProbesTest, FrontOfNegativeCoordinates) {
  const Model model = TestModel();
  const State state = MakeState({Vec3(-3, -2, -5), Vec3(-1.5f, -4, -6)});
  ProbeSpec probe = Probe(ProbeKind::kFront, "front");
  probe.axis = 0;
  EXPECT_EQ(Evaluate1(probe, model, state), -1.5);
  probe.axis = 1;
  EXPECT_EQ(Evaluate1(probe, model, state), -2.0);
}

TEST(ProbesTest, HeightAtAPointWithARadius) {
  const Model model = TestModel();  // floor at y = -1
  // A column at (2, 2) up to y = 1.5, a taller one at (3, 2) up to y = 2.5.
  const State state = MakeState({Vec3(2.0f, -1.0f, 2.0f), Vec3(2.1f, 0.5f, 2.0f),
                                 Vec3(2.0f, 1.5f, 1.9f), Vec3(3.0f, 2.5f, 2.0f)});
  ProbeSpec probe = Probe(ProbeKind::kHeight, "h");
  probe.point = Vec3d(2, 100, 2);  // the y of the point does not matter
  probe.radius = 0.3;
  probe.gap = 2;  // these sparse columns are connected
  EXPECT_NEAR(Evaluate1(probe, model, state), 1.5 - (-1.0), 1e-6);
  probe.radius = 1.0;  // now reaches the column at x = 3
  EXPECT_NEAR(Evaluate1(probe, model, state), 2.5 - (-1.0), 1e-6);
  // radius 0 means the smoothing radius (0.5): the x = 3 column is 1 away, out of reach.
  probe.radius = 0;
  EXPECT_NEAR(Evaluate1(probe, model, state), 2.5, 1e-6);
  // No particle near: height 0.
  probe.point = Vec3d(0.2, 0, 0.2);
  probe.radius = 0.3;
  EXPECT_EQ(Evaluate1(probe, model, state), 0.0);
}

TEST(ProbesTest, HeightCountsTheConnectedColumnAndNotTheSprayAboveIt) {
  const Model model = TestModel();  // floor at y = -1, kernel support 0.5
  // A column every 0.1 m from the floor up to 0.6 m, and drops at 1.2 m and 2.0 m above it.
  std::vector<Vec3> positions;
  for (int k = 0; k <= 6; ++k) positions.push_back(Vec3(1.0f, -1.0f + 0.1f * float(k), 1.0f));
  positions.push_back(Vec3(1.05f, 0.2f, 1.0f));
  positions.push_back(Vec3(0.95f, 1.0f, 1.0f));
  const State state = MakeState(positions);
  ProbeSpec probe = Probe(ProbeKind::kHeight, "h");
  probe.point = Vec3d(1, 0, 1);
  probe.radius = 0.2;
  EXPECT_NEAR(Evaluate1(probe, model, state), 0.6, 1e-6);  // gap 0 = the support: drops apart
  probe.gap = 0.7;  // reaches the first drop (0.6 above the column's top), not the second
  EXPECT_NEAR(Evaluate1(probe, model, state), 1.2, 1e-6);
  probe.gap = 0.8;
  EXPECT_NEAR(Evaluate1(probe, model, state), 2.0, 1e-6);
  // A sheet flying above a dry floor: no column.
  const State spray = MakeState({Vec3(1.0f, 0.5f, 1.0f), Vec3(1.0f, 0.6f, 1.0f)});
  probe.gap = 0;
  EXPECT_EQ(Evaluate1(probe, model, spray), 0.0);
  EXPECT_NEAR(ConnectedColumnHeight(state.particles, model, Vec3d(1, 0, 1), 0.2, 0.5, -1.0), 0.6,
              1e-6);
}

TEST(ProbesTest, PressureOfAUniformFieldIsThatPressure) {
  const Model model = TestModel();
  std::vector<Vec3> positions;
  for (int x = 0; x < 8; ++x) {
    for (int y = 0; y < 8; ++y) {
      for (int z = 0; z < 8; ++z) positions.push_back(Vec3(1, 0, 1) + Vec3(x, y, z) * 0.15f);
    }
  }
  State state = MakeState(positions);
  for (Real& p : state.particles.pressure) p = 1234.5f;
  ProbeSpec probe = Probe(ProbeKind::kPressure, "p");
  for (const Vec3d& point : {Vec3d(1.5, 0.5, 1.5), Vec3d(1.0, 0.0, 1.0), Vec3d(2.1, 1.1, 1.3)}) {
    probe.point = point;
    EXPECT_NEAR(Evaluate1(probe, model, state), 1234.5, 1e-9 * 1234.5) << point.transpose();
  }
  // Far from every particle: 0.
  probe.point = Vec3d(3.9, 2.9, 3.9);
  EXPECT_EQ(Evaluate1(probe, model, state), 0.0);
}

TEST(ProbesTest, PressureIsAPoly6WeightedAverage) {
  const Model model = TestModel();  // h = 0.5
  State state = MakeState({Vec3(1, 1, 1), Vec3(1.3f, 1, 1), Vec3(3, 1, 1)});
  state.particles.pressure = {100, 400, 1e6};
  ProbeSpec probe = Probe(ProbeKind::kPressure, "p");
  probe.point = Vec3d(1.1, 1, 1);
  const double r0 = 0.1;
  const double r1 = double(1.3f) - 1.1;
  const double w0 = Poly6<double>::W(r0, 0.5);
  const double w1 = Poly6<double>::W(r1, 0.5);
  EXPECT_NEAR(Evaluate1(probe, model, state), (100 * w0 + 400 * w1) / (w0 + w1), 1e-9);
}

// A column of water on a lattice of spacing 0.1 against a wall face at x = 0.95 (normal +x),
// rho = 1000 and the hydrostatic pressure p = rho |g| (H - y) of gravity -10 (the seed model's
// default), with H = 1.
State HydrostaticColumn(double face_x) {
  std::vector<Vec3> positions;
  for (int x = 0; x < 6; ++x) {
    for (int y = 0; y < 10; ++y) {
      for (int z = 0; z < 6; ++z) {
        positions.push_back(
            Vec3(Real(face_x + 0.05 + 0.1 * x), Real(0.05 + 0.1 * y), Real(1.75 + 0.1 * z)));
      }
    }
  }
  State state = MakeState(positions);
  for (size_t i = 0; i < positions.size(); ++i) {
    state.particles.density[i] = 1000;
    state.particles.pressure[i] = Real(1000 * 10 * (1.0 - positions[i].y()));
  }
  return state;
}

TEST(ProbesTest, WallPressureOfAHydrostaticColumnIsRhoGDepthAtTheSensor) {
  const Model model = TestModel();  // support 0.5, gravity -10
  const State state = HydrostaticColumn(0.95);
  ProbeSpec probe = Probe(ProbeKind::kWallPressure, "p");
  probe.normal = Vec3d(1, 0, 0);
  // On the face, from the floor up: every particle's pressure carried to the sensor's height is
  // rho g (H - y_s), so the reading is exact wherever the support reaches fluid, near the floor
  // and the surface too (where the particles around lie on one side of the sensor's height).
  for (const double y : {0.0, 0.02, 0.3, 0.55, 0.9}) {
    probe.point = Vec3d(0.95, y, 2.0);
    EXPECT_NEAR(Evaluate1(probe, model, state), 1000 * 10 * (1.0 - y), 0.05) << "y = " << y;
  }
  // The plain interpolation reads the mean pressure of the particles around, which at the floor
  // all lie above the sensor: it misses rho g h there by more than 10%.
  ProbeSpec plain = Probe(ProbeKind::kPressure, "p");
  plain.point = Vec3d(0.95, 0.0, 2.0);
  EXPECT_LT(Evaluate1(plain, model, state), 0.9 * 1000 * 10);
}

TEST(ProbesTest, WallPressureInAirIsZero) {
  const Model model = TestModel();
  const State state = HydrostaticColumn(0.95);
  ProbeSpec probe = Probe(ProbeKind::kWallPressure, "p");
  probe.normal = Vec3d(1, 0, 0);
  // Above the water (H = 1) by more than the support, and far along the wall: dry sensors.
  probe.point = Vec3d(0.95, 1.6, 2.0);
  EXPECT_EQ(Evaluate1(probe, model, state), 0.0);
  probe.point = Vec3d(0.95, 0.5, 3.5);
  EXPECT_EQ(Evaluate1(probe, model, state), 0.0);
  // Within the support of the surface particles but above them: their pressure carried up to
  // the sensor is negative (air does not pull on a sensor), so it reads 0.
  probe.point = Vec3d(0.95, 1.3, 2.0);
  EXPECT_EQ(Evaluate1(probe, model, state), 0.0);
}

TEST(ProbesTest, WallPressureCountsOnlyTheFluidOnTheNormalsSide) {
  const Model model = TestModel();
  State state = HydrostaticColumn(0.95);
  // Water at ten times the pressure behind the face (x < 0.95), within the support of a sensor
  // on it: a sensor sees the side its face looks into.
  const size_t front = state.particles.size();
  std::vector<Vec3> positions(state.particles.position);
  for (int y = 0; y < 10; ++y) positions.push_back(Vec3(0.9f, Real(0.05 + 0.1 * y), 2.05f));
  State both = MakeState(positions);
  for (size_t i = 0; i < positions.size(); ++i) {
    both.particles.density[i] = 1000;
    both.particles.pressure[i] = Real((i < front ? 1 : 10) * 1000 * 10 * (1.0 - positions[i].y()));
  }
  ProbeSpec probe = Probe(ProbeKind::kWallPressure, "p");
  probe.point = Vec3d(0.95, 0.5, 2.0);
  probe.normal = Vec3d(3, 0, 0);  // any length
  EXPECT_NEAR(Evaluate1(probe, model, both), 5000, 0.05);
  // Without a normal every particle around counts, and the ones behind the face raise it.
  probe.normal = Vec3d::Zero();
  EXPECT_GT(Evaluate1(probe, model, both), 6000);
}

TEST(ProbesTest, WallPressureTakesTheGravityOfTheTime) {
  Scene scene;
  scene.domain = Aabb{Vec3d(0, -1, 0), Vec3d(4, 3, 4)};
  Params params;
  params.smoothing_radius = 0.5;
  params.gravity_ramp_time = 1.0;  // gravity 0 at t = 0, all of it from t = 1 s
  const Model model = MakeModel(scene, params);
  State state = HydrostaticColumn(0.95);
  const Vec3d sensor(0.95, 0.3, 2.0);
  EXPECT_NEAR(WallPressureAt(state.particles, model, sensor, Vec3d(1, 0, 0), 2.0), 7000, 0.05);
  // At t = 0 no correction: the cubic-spline Shepard average of the particles' pressures.
  double weighted = 0, weights = 0;
  for (size_t i = 0; i < state.particles.size(); ++i) {
    const double w =
        CubicSpline<double>::W((state.particles.position[i].cast<double>() - sensor).norm(), 0.5);
    weighted += w * state.particles.pressure[i];
    weights += w;
  }
  EXPECT_NEAR(WallPressureAt(state.particles, model, sensor, Vec3d(1, 0, 0), 0.0),
              weighted / weights, 1e-6 * weighted / weights);
}

TEST(ProbesTest, DensityMeanAndMax) {
  const Model model = TestModel();
  State state = MakeState({Vec3(1, 1, 1), Vec3(2, 1, 1), Vec3(3, 1, 1), Vec3(1, 2, 1)});
  state.particles.density = {600, 640.5f, 700.25f, 580};
  const std::vector<ProbeSpec> probes = {Probe(ProbeKind::kDensity, "rho")};
  const std::vector<double> values = EvaluateProbes(probes, model, state);
  ASSERT_EQ(values.size(), 2u);
  EXPECT_DOUBLE_EQ(values[0], (600 + 640.5 + 700.25 + 580) / 4);
  EXPECT_EQ(values[1], 700.25);
}

TEST(ProbesTest, KineticEnergyIsHalfMassTimesSpeedSquared) {
  const Model model = TestModel();  // mass 2
  const State state = MakeState({Vec3(1, 1, 1), Vec3(2, 1, 1), Vec3(3, 1, 1)},
                                {Vec3(1, 0, 0), Vec3(0, -2, 0), Vec3(1, 2, -3)});
  // 0.5 * 2 * (1 + 4 + 14)
  EXPECT_DOUBLE_EQ(Evaluate1(Probe(ProbeKind::kKineticEnergy, "ke"), model, state), 19.0);
  EXPECT_EQ(Evaluate1(Probe(ProbeKind::kKineticEnergy, "ke"), model, MakeState({})), 0.0);
}

TEST(ProbesTest, CountInsideARegionAndTheDomain) {
  const Model model = TestModel();  // domain [0, 4] x [-1, 3] x [0, 4]
  const State state = MakeState({
      Vec3(1, 1, 1),        // inside both
      Vec3(0, -1, 0),       // on the domain corner: inside (closed box)
      Vec3(4, 3, 4),        // the other corner
      Vec3(2.5f, 0, 2.5f),  // in the domain, outside the region
      Vec3(-0.5f, 1, 1),    // outside the domain
      Vec3(1, 1, 4.01f),    // outside the domain
  });
  ProbeSpec probe = Probe(ProbeKind::kCountInside, "n");
  EXPECT_EQ(Evaluate1(probe, model, state), 4.0);
  probe.region = Aabb{Vec3d(0.5, 0.5, 0.5), Vec3d(2, 2, 2)};
  EXPECT_EQ(Evaluate1(probe, model, state), 1.0);
  probe.region = Aabb{Vec3d(-1, -1, 0), Vec3d(1, 1, 4.5)};
  EXPECT_EQ(Evaluate1(probe, model, state), 4.0);  // (1,1,1), (0,-1,0), (-0.5,1,1), (1,1,4.01)
}

TEST(ProbesTest, ValuesComeInColumnOrder) {
  const Model model = TestModel();
  State state = MakeState({Vec3(1, 1, 1), Vec3(2, 2, 2)}, {Vec3(1, 0, 0), Vec3(0, 1, 0)});
  state.particles.density = {10, 30};
  ProbeSpec front = Probe(ProbeKind::kFront, "fy");
  front.axis = 1;
  const std::vector<ProbeSpec> probes = {Probe(ProbeKind::kCountInside, "n"),
                                         Probe(ProbeKind::kDensity, "rho"), front,
                                         Probe(ProbeKind::kKineticEnergy, "ke")};
  EXPECT_EQ(EvaluateProbes(probes, model, state), (std::vector<double>{2, 20, 30, 2, 2}));
}

}  // namespace
}  // namespace dysa
