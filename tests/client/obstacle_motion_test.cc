// Tests of the client's ObstacleMotion::DisplacementAt (clients/cpp/src/obstacle_motion.cc): it
// gives the core's displacement (server/core/src/obstacle_motion.cc) at every time, so a viewer
// draws an obstacle where the solver had it.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <vector>

#include "dysa/client/types.h"
#include "dysa/core/scene.h"

namespace {

using Keys = std::vector<std::array<double, 4>>;  // t, dx, dy, dz

dysa::remote::ObstacleMotion ClientMotion(const Keys& keys) {
  dysa::remote::ObstacleMotion m;
  for (const auto& k : keys) m.keys.push_back({k[0], {k[1], k[2], k[3]}});
  return m;
}

dysa::ObstacleMotion CoreMotion(const Keys& keys) {
  dysa::ObstacleMotion m;
  for (const auto& k : keys) m.keys.push_back({k[0], dysa::Vec3d(k[1], k[2], k[3])});
  return m;
}

void ExpectSameAsCore(const Keys& keys, const std::vector<double>& times) {
  const dysa::remote::ObstacleMotion client = ClientMotion(keys);
  const dysa::ObstacleMotion core = CoreMotion(keys);
  EXPECT_EQ(client.moving(), core.moving());
  for (double t : times) {
    const std::array<double, 3> d = client.DisplacementAt(t);
    const dysa::Vec3d expected = core.DisplacementAt(t);
    for (int a = 0; a < 3; ++a) EXPECT_DOUBLE_EQ(d[a], expected[a]) << "t " << t << " axis " << a;
  }
}

TEST(ClientObstacleMotionTest, StaticIsNoDisplacement) {
  const dysa::remote::ObstacleMotion none;
  EXPECT_FALSE(none.moving());
  EXPECT_EQ(none.DisplacementAt(3.0), (std::array<double, 3>{0, 0, 0}));
}

TEST(ClientObstacleMotionTest, VelocityFormRestsMovesAndStopsAsTheCoreHasIt) {
  // "velocity": [2, 0, -1], "start": 0.5, "end": 1.5.
  const Keys keys = {{0.5, 0, 0, 0}, {1.5, 2, 0, -1}};
  ExpectSameAsCore(keys, {0, 0.25, 0.5, 0.75, 1.0, 1.4999, 1.5, 2, 1e6});
  const std::array<double, 3> mid = ClientMotion(keys).DisplacementAt(1.0);
  EXPECT_DOUBLE_EQ(mid[0], 1.0);
  EXPECT_DOUBLE_EQ(mid[2], -0.5);
}

TEST(ClientObstacleMotionTest, PathIsLinearBetweenKeysAndHeldOutsideThem) {
  const Keys path = {{0.1, 1, 0, 0}, {0.2, 1, 0.1, 0}, {0.4, 0, 0.4, -2}, {1.0, 0, 0, 0}};
  ExpectSameAsCore(path, {0, 0.1, 0.15, 0.2, 0.3, 0.39, 0.4, 0.7, 1.0, 5.0});
  const std::array<double, 3> before = ClientMotion(path).DisplacementAt(0);
  EXPECT_EQ(before, (std::array<double, 3>{1, 0, 0}));
  // One key: a fixed offset at every time.
  ExpectSameAsCore({{2.0, 0.5, -0.5, 0.25}}, {0, 2.0, 3.0});
}

TEST(ClientObstacleMotionTest, AKeyTimeThatIsNotANumberGivesAFiniteDisplacement) {
  // dysa-server never sends one (ParseScene refuses it); from another server the obstacle must
  // still be drawn somewhere rather than at NaN.
  const dysa::remote::ObstacleMotion bad =
      ClientMotion({{0, 0, 0, 0}, {NAN, 1, 0, 0}, {2, 3, 0, 0}});
  for (double t : {-1.0, 0.0, 0.5, 1.0, 1.5, 2.0, 3.0}) {
    for (double d : bad.DisplacementAt(t)) EXPECT_TRUE(std::isfinite(d)) << t;
  }
}

}  // namespace
