// Tests of the box_force probe (server/core/src/box_force_probe.cc, probes.h BoxForceOn) on
// hand-built hydrostatic states whose force has a closed form, and against its definition (the
// wall pressure read at every patch centre of every face).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "dysa/core/model.h"
#include "dysa/core/probes.h"

namespace dysa {
namespace {

constexpr double kRho = 1000;  // kg/m^3
constexpr double kG = 10;      // m/s^2, the seed model's default gravity (-10 along y)
constexpr double kDepth = 1;   // m, the water's surface at y = 1

// The seed model (support 0.5 m, gravity -10) in the domain [0, 4] x [0, 3] x [0, 4] with the
// given box obstacles.
Model BoxModel(const std::vector<BoxObstacle>& boxes) {
  Scene scene;
  scene.domain = Aabb{Vec3d(0, 0, 0), Vec3d(4, 3, 4)};
  scene.boxes = boxes;
  Params params;
  params.smoothing_radius = 0.5;
  return MakeModel(scene, params);
}

// Water at rest on a lattice of spacing 0.1 filling `region` (up to y = kDepth), outside every
// box of the model, with the hydrostatic pressure rho g (H - y).
State StillWater(const Aabb& region, const Model& model) {
  State state;
  std::vector<Vec3> positions;
  for (double x = region.min.x() + 0.05; x < region.max.x(); x += 0.1) {
    for (double y = region.min.y() + 0.05; y < std::min(region.max.y(), kDepth); y += 0.1) {
      for (double z = region.min.z() + 0.05; z < region.max.z(); z += 0.1) {
        const Vec3d p(x, y, z);
        bool inside = false;
        for (const BoxObstacle& b : model.boxes) inside = inside || b.box.Contains(p);
        if (!inside) positions.push_back(p.cast<Real>());
      }
    }
  }
  state.particles.Resize(positions.size());
  for (size_t i = 0; i < positions.size(); ++i) {
    state.particles.id[i] = uint32_t(i);
    state.particles.position[i] = positions[i];
    state.particles.velocity[i] = Vec3::Zero();
    state.particles.density[i] = Real(kRho);
    state.particles.pressure[i] = Real(kRho * kG * (kDepth - positions[i].y()));
  }
  return state;
}

TEST(BoxForceProbeTest, WaterOnOneSidePushesWithHalfRhoGDepthSquaredPerWidth) {
  // A wall of a box 1 m wide (z), 2 m tall, with water 1 m deep against its +x face only.
  const Model model = BoxModel({{Aabb{Vec3d(0.5, 0, 1.5), Vec3d(0.95, 2, 2.5)}, {}}});
  const State state = StillWater(Aabb{Vec3d(0.95, 0, 1.5), Vec3d(1.55, 3, 2.5)}, model);
  const Vec3d force = BoxForceOn(state.particles, model, 0, 0.05, 0);
  // The midpoint rule is exact for the linear pressure; above the surface the reading is 0.
  const double push = 0.5 * kRho * kG * kDepth * kDepth * 1.0;  // 5,000 N
  EXPECT_NEAR(force.x(), -push, 1e-4 * push);
  EXPECT_EQ(force.y(), 0.0);  // no water above the top or under the floor face
  EXPECT_EQ(force.z(), 0.0);  // nor beside the side faces
  // The patch size does not matter for a linear pressure as long as the surface falls on a
  // patch edge (0.1 m patches: 10 below the surface).
  EXPECT_NEAR(BoxForceOn(state.particles, model, 0, 0.1, 0).x(), -push, 1e-4 * push);
  // Half the depth is on the face's lower half: a force probe of a box only that tall reads
  // rho g W (H^2 - (H - h)^2) / 2 for h = 0.5.
  const Model low = BoxModel({{Aabb{Vec3d(0.5, 0, 1.5), Vec3d(0.95, 0.5, 2.5)}, {}}});
  EXPECT_NEAR(BoxForceOn(state.particles, low, 0, 0.05, 0).x(), -0.5 * kRho * kG * (1 - 0.25),
              1e-4 * push);
}

TEST(BoxForceProbeTest, ASubmergedBoxOnTheFloorIsPressedDownByTheWaterAboveIt) {
  // A box 0.4 m on each side on the floor in the middle of a tank of water 1 m deep: the side
  // faces' pushes cancel, the top carries rho g (H - 0.4) over 0.16 m^2, and nothing is under it.
  const Aabb box{Vec3d(1.8, 0, 1.8), Vec3d(2.2, 0.4, 2.2)};
  const Model model = BoxModel({{box, {}}});
  const State state = StillWater(Aabb{Vec3d(1, 0, 1), Vec3d(3, 3, 3)}, model);
  const Vec3d force = BoxForceOn(state.particles, model, 0, 0, 0);         // patches of 0.4 m
  const double side = kRho * kG * (kDepth * 0.4 - 0.5 * 0.4 * 0.4) * 0.4;  // 1,280 N a face
  EXPECT_NEAR(force.y(), -kRho * kG * (kDepth - 0.4) * 0.16, 1e-4 * side);
  EXPECT_NEAR(force.x(), 0.0, 1e-6 * side);
  EXPECT_NEAR(force.z(), 0.0, 1e-6 * side);
}

TEST(BoxForceProbeTest, EqualsTheWallPressureSummedOverEveryPatchCentre) {
  // A box whose faces meet the water on several sides, read with patches that do not divide its
  // edges into whole multiples of anything: the probe must be, bit for bit, the definition.
  const Aabb box{Vec3d(1.23, 0.1, 1.31), Vec3d(1.71, 0.77, 1.93)};
  const Model model = BoxModel({{box, {}}});
  // Water over the box and on its -x and -z sides, not on its +x and +z ones.
  State state = StillWater(Aabb{Vec3d(0.6, 0, 0.8), Vec3d(1.6, 3, 1.8)}, model);
  // Disturb the pressures so that no symmetry or linearity helps.
  for (size_t i = 0; i < state.particles.size(); ++i) {
    state.particles.pressure[i] += Real(300 * std::sin(7.0 * double(i)));
  }
  const double spacing = 0.07;
  Vec3d expected = Vec3d::Zero();
  for (int a = 0; a < 3; ++a) {
    const int u = (a + 1) % 3, v = (a + 2) % 3;
    const int nu = int(std::ceil((box.max[u] - box.min[u]) / spacing));
    const int nv = int(std::ceil((box.max[v] - box.min[v]) / spacing));
    const double du = (box.max[u] - box.min[u]) / nu, dv = (box.max[v] - box.min[v]) / nv;
    for (const double side : {-1.0, 1.0}) {
      Vec3d normal = Vec3d::Zero();
      normal[a] = side;
      double sum = 0;
      for (int i = 0; i < nu; ++i) {
        for (int j = 0; j < nv; ++j) {
          Vec3d point;
          point[a] = side < 0 ? box.min[a] : box.max[a];
          point[u] = box.min[u] + (i + 0.5) * du;
          point[v] = box.min[v] + (j + 0.5) * dv;
          sum += WallPressureAt(state.particles, model, point, normal, 0) * (du * dv);
        }
      }
      expected[a] -= side * sum;
    }
  }
  const Vec3d force = BoxForceOn(state.particles, model, 0, spacing, 0);
  EXPECT_EQ(force.x(), expected.x());
  EXPECT_EQ(force.y(), expected.y());
  EXPECT_EQ(force.z(), expected.z());
  // Not vacuous: every axis carries a force.
  EXPECT_GT(std::abs(expected.x()), 10.0);
  EXPECT_GT(std::abs(expected.y()), 10.0);
  EXPECT_GT(std::abs(expected.z()), 10.0);
}

TEST(BoxForceProbeTest, AMovingBoxIsReadWhereItStandsAtTheTime) {
  // The one-sided wall of the first test, carried 0.2 m towards -x over the first second and
  // 1 m more in the third: at t = 1.5 s its face stands at x = 0.75, within the support (0.5 m)
  // of the water, and reads what a static box there reads; at t = 3 s, 1.25 m from the water,
  // nothing.
  BoxObstacle moving{Aabb{Vec3d(0.5, 0, 1.5), Vec3d(0.95, 2, 2.5)}, {}};
  moving.motion.keys = {
      {0, Vec3d::Zero()}, {1, Vec3d(-0.2, 0, 0)}, {2, Vec3d(-0.2, 0, 0)}, {3, Vec3d(-1.2, 0, 0)}};
  const Model model = BoxModel({moving});
  const Model there = BoxModel({{Aabb{Vec3d(0.3, 0, 1.5), Vec3d(0.75, 2, 2.5)}, {}}});
  const State state = StillWater(Aabb{Vec3d(0.95, 0, 1.5), Vec3d(1.55, 3, 2.5)}, model);
  EXPECT_EQ(BoxForceOn(state.particles, model, 0, 0.05, 1.5),
            BoxForceOn(state.particles, there, 0, 0.05, 0));
  EXPECT_LT(BoxForceOn(state.particles, model, 0, 0.05, 1.5).x(), -1000);
  EXPECT_EQ(BoxForceOn(state.particles, model, 0, 0.05, 3.0), Vec3d::Zero());
}

TEST(BoxForceProbeTest, ItsColumnsAreTheThreeAxesAndABadBoxThrows) {
  ProbeSpec probe;
  probe.kind = ProbeKind::kBoxForce;
  probe.name = "F";
  probe.box = 0;
  EXPECT_EQ(ProbeColumns(std::span(&probe, 1)), (std::vector<std::string>{"F_x", "F_y", "F_z"}));
  const Model model = BoxModel({{Aabb{Vec3d(0.5, 0, 1.5), Vec3d(0.95, 2, 2.5)}, {}}});
  const State state = StillWater(Aabb{Vec3d(0.95, 0, 1.5), Vec3d(1.55, 3, 2.5)}, model);
  const std::vector<double> values = EvaluateProbes(std::span(&probe, 1), model, state);
  ASSERT_EQ(values.size(), 3u);
  const Vec3d force = BoxForceOn(state.particles, model, 0, 0, 0);
  EXPECT_EQ(values[0], force.x());
  EXPECT_EQ(values[1], force.y());
  EXPECT_EQ(values[2], force.z());
  EXPECT_THROW(BoxForceOn(state.particles, model, 1, 0, 0), std::out_of_range);
}

}  // namespace
}  // namespace dysa
