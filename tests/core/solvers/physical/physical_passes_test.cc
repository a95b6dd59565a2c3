// Tests of server/core/src/solvers/physical/physical_passes.{h,cc}: the wall contact
// (LimitApproachToSurfaces) stops a particle Params::wall_contact_range / 2 spacings from a
// wall, cutting only its velocity towards it.
#include "solvers/physical/physical_passes.h"

#include <gtest/gtest.h>

namespace dysa {
namespace {

constexpr double kSpacing = 0.01;  // m
constexpr Real kDt = 1e-3;         // s

// A wcsph model in a 1 m box (floor at y = 0) with this wall contact range.
Model WithContactRange(double range) {
  Scene scene;
  scene.solver = "wcsph";
  scene.domain = Aabb{Vec3d(0, 0, 0), Vec3d(1, 1, 1)};
  scene.params.particle_spacing = kSpacing;
  scene.params.wall_contact_range = range;
  return MakeModel(scene, scene.params);
}

// The height above the floor after a step of kDt from `height`, falling at `speed` and drifting
// sideways at 1 m/s; checks that the sideways velocity is left alone.
Real HeightAfterStep(double range, Real height, Real speed) {
  const Model model = WithContactRange(range);
  const Vec3 x(0.5, height, 0.5);
  Vec3 v(1, -speed, 0);
  physical::LimitApproachToSurfaces(model, {}, kDt, x, v);
  EXPECT_EQ(v.x(), 1) << "only the velocity towards the wall is cut";
  EXPECT_EQ(v.z(), 0);
  return x.y() + v.y() * kDt;
}

TEST(WallContactTest, StopsAParticleHalfTheRangeFromTheWall) {
  const Real from = Real(0.6 * kSpacing);
  // Falling 2 spacings in the step: held at r0 / 2 for each range (0.2 d by default).
  for (double range : {0.4, 0.1, 1.0}) {
    EXPECT_NEAR(HeightAfterStep(range, from, Real(2 * kSpacing / kDt)), 0.5 * range * kSpacing,
                1e-7)
        << "range " << range;
  }
  // Range 0: the cut acts only at the wall itself.
  EXPECT_NEAR(HeightAfterStep(0, from, Real(2 * kSpacing / kDt)), 0, 1e-7);
}

TEST(WallContactTest, LeavesAParticleThatStaysOutOfRangeAlone) {
  // Falling 0.1 spacing in the step from 0.6: it ends at 0.5, beyond the default's 0.2.
  EXPECT_NEAR(HeightAfterStep(0.4, Real(0.6 * kSpacing), Real(0.1 * kSpacing / kDt)),
              0.5 * kSpacing, 1e-7);
}

}  // namespace
}  // namespace dysa
