// Tests of server/core/src/solvers/physical/cfl_time_step.{h,cc}: each limit of the adaptive step
// binds when it is the smallest, and a step never overshoots the point it must stop at.
#include "solvers/physical/cfl_time_step.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace dysa {
namespace {

// The model of a wcsph scene with these parameters (its viscosity moment among them).
Model Physical(double nu = 1e-6, double max_time_step = 1) {
  Scene scene;
  scene.solver = "wcsph";
  Params& p = scene.params;
  p.particle_spacing = 0.01;
  p.speed_of_sound = 20;
  p.cfl_factor = 0.25;
  p.kinematic_viscosity = nu;
  p.max_time_step = max_time_step;
  return MakeModel(scene, p);
}

TEST(CflLimitsTest, SoundLimitGrowsSlowerWithSpeed) {
  const Model p = Physical();
  const TimeStepLimits still = CflLimits(p, 0, 0);
  EXPECT_DOUBLE_EQ(still.sound, 0.25 * 0.01 / 20);
  EXPECT_EQ(still.force, TimeStepLimits::kNone);  // no acceleration: no force limit
  EXPECT_DOUBLE_EQ(still.Min(), still.sound);
  EXPECT_DOUBLE_EQ(CflLimits(p, 5, 0).sound, 0.25 * 0.01 / 25);
}

TEST(CflLimitsTest, ViscousForceAndMaxLimitsBindWhenSmallest) {
  // 0.125 lambda h^2 / nu = 8.85e-6 s < sound 1.25e-4 s, lambda = 0.708 (the viscosity moment)
  const Model viscous = Physical(1);
  EXPECT_NEAR(viscous.viscosity_moment, 0.708, 0.001);
  EXPECT_DOUBLE_EQ(CflLimits(viscous, 0, 0).Min(),
                   0.125 * viscous.viscosity_moment * 0.01 * 0.01 / 1);
  const double a = 1e5;  // 0.25 sqrt(h / a) = 7.9e-5 s
  EXPECT_DOUBLE_EQ(CflLimits(Physical(), 0, a).Min(), 0.25 * std::sqrt(0.01 / a));
  EXPECT_DOUBLE_EQ(CflLimits(Physical(1e-6, 1e-6), 0, a).Min(), 1e-6);
  EXPECT_EQ(CflLimits(Physical(0), 0, 0).viscous, TimeStepLimits::kNone);
}

// wcsph's artificial viscosity alpha joins the viscous limit as the laminar viscosity
// lambda alpha h c0 / 10 (h the smoothing length); the incompressible limit (dfsph, no c0) and
// alpha = 0 leave the limit as it was.
TEST(CflLimitsTest, ArtificialViscosityJoinsTheViscousLimit) {
  Model model = Physical(0);
  model.params.artificial_viscosity = 0.05;
  const double lambda = model.viscosity_moment;
  const double artificial = lambda * 0.05 * 20 * model.SmoothingLength() / 10;
  EXPECT_DOUBLE_EQ(CflLimits(model, 0, 0).viscous, 0.125 * lambda * 0.01 * 0.01 / artificial);
  // 1.25 h / (alpha c0) = 0.0125 s: far above the sound limit, which still binds.
  EXPECT_DOUBLE_EQ(CflLimits(model, 0, 0).viscous, 1.25 * 0.01 / (0.05 * 20));
  EXPECT_DOUBLE_EQ(CflLimits(model, 0, 0).Min(), 0.25 * 0.01 / 20);
  EXPECT_EQ(CflLimits(model, 0, 0, /*acoustic=*/false).viscous, TimeStepLimits::kNone);
  model.params.kinematic_viscosity = 1e-3;
  EXPECT_DOUBLE_EQ(CflLimits(model, 0, 0).viscous,
                   0.125 * lambda * 0.01 * 0.01 / (1e-3 + artificial));
  EXPECT_DOUBLE_EQ(CflLimits(model, 0, 0, false).viscous, 0.125 * lambda * 0.01 * 0.01 / 1e-3);
  model.params.artificial_viscosity = 0;
  EXPECT_EQ(CflLimits(model, 0, 0).viscous, CflLimits(Physical(1e-3), 0, 0).viscous);
}

TEST(ChooseTimeStepTest, TakesTheRestOrSplitsItEvenly) {
  TimeStepLimits limits;
  limits.sound = 1.0;
  EXPECT_EQ(ChooseTimeStep(limits, TimeStepLimits::kNone), 1.0);
  EXPECT_EQ(ChooseTimeStep(limits, 5.0), 1.0);
  EXPECT_EQ(ChooseTimeStep(limits, 0.4), 0.4);  // fits: all of it
  EXPECT_EQ(ChooseTimeStep(limits, 1.0), 1.0);
  EXPECT_EQ(ChooseTimeStep(limits, 1.5), 0.75);  // two steps anyway: no sliver
  EXPECT_EQ(ChooseTimeStep(limits, 2.0), 1.0);
  EXPECT_EQ(ChooseTimeStep(limits, 0.0), 1.0);  // no cap
}

// Past its speed of sound the weakly compressible model does not hold: the step warns (the
// stress suite's block falling at 2 m/s with c0 = 0.1 m/s), naming both speeds; a subsonic flow
// (the Poiseuille channel's 0.25 mm/s at the same c0) does not.
TEST(SupersonicWarningTest, WarnsOnlyPastTheSpeedOfSound) {
  Params params;
  params.speed_of_sound = 0.1;
  const std::string warning = SupersonicWarning(params, 2.0);
  EXPECT_NE(warning.find("2.000000 m/s"), std::string::npos) << warning;
  EXPECT_NE(warning.find("speed_of_sound 0.100000"), std::string::npos) << warning;
  EXPECT_EQ(SupersonicWarning(params, 2.5e-4), "");
  EXPECT_EQ(SupersonicWarning(params, 0.1), "");  // at c0 exactly: not past it
  params.speed_of_sound = 50;
  EXPECT_EQ(SupersonicWarning(params, 4.6), "");
}

}  // namespace
}  // namespace dysa
