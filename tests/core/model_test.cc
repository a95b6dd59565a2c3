// Tests of MakeModel (server/core/src/model.cc): the seed model's and the physical solvers'
// particle mass, kernel support, step and lattice moments; the domain's bounds rounded to float;
// no-slip walls only on axes that are not periodic; and a periodic axis too short for the
// parameters refused with a ConfigError naming the parameter.
#include "dysa/core/model.h"

#include <gtest/gtest.h>

#include <string>

#include "dysa/core/kernels.h"
#include "dysa/core/params.h"
#include "dysa/core/scene.h"

namespace dysa {
namespace {

TEST(MakeModelTest, SeedTakesItsOwnMassAndSmoothingRadiusAndMomentsOfOne) {
  Scene scene = ParseScene(R"({"fluid_blocks": [{}]})");
  SetParam(scene.params, "particle_mass", 2.5);
  SetParam(scene.params, "smoothing_radius", 0.35);
  const Model model = MakeModel(scene, scene.params);
  EXPECT_FALSE(model.physical);
  EXPECT_EQ(model.particle_mass, 2.5);
  EXPECT_EQ(model.kernel_support, 0.35);
  EXPECT_EQ(model.gradient_moment, 1);
  EXPECT_EQ(model.viscosity_moment, 1);
  EXPECT_EQ(model.params.smoothing_radius, 0.35);
  const Params& p = scene.params;
  EXPECT_DOUBLE_EQ(model.dt, p.time_scale / (p.frame_rate * p.iterations_per_frame));
  EXPECT_DOUBLE_EQ(model.FrameTime(), p.time_scale / p.frame_rate);
}

TEST(MakeModelTest, PhysicalSolversDeriveMassSupportAndMomentsFromTheSpacing) {
  for (const char* solver : {"wcsph", "dfsph"}) {
    SCOPED_TRACE(solver);
    Scene scene =
        ParseScene(std::string(R"({"solver": ")") + solver + R"(", "fluid_blocks": [{}]})");
    SetParam(scene.params, "particle_spacing", 0.02);
    SetParam(scene.params, "rest_density", 998);
    const Model model = MakeModel(scene, scene.params);
    EXPECT_TRUE(model.physical);
    EXPECT_DOUBLE_EQ(model.particle_mass, 998 * 0.02 * 0.02 * 0.02);
    EXPECT_DOUBLE_EQ(model.kernel_support, 0.04);
    const PhysicalKernel<double> cubic{KernelKind::kCubicSpline, 0.04};
    EXPECT_EQ(model.kernel_kind, KernelKind::kCubicSpline);
    EXPECT_EQ(model.gradient_moment, LatticeGradientMoment(cubic, 0.02));
    EXPECT_EQ(model.viscosity_moment, LatticeViscosityMoment(cubic, 0.02));
    // Not 1: the lattice's moments are what the pressure and viscous terms are divided by
    // (about 1.02 and 0.708, docs/validation.md).
    EXPECT_NEAR(model.gradient_moment, 1.02, 0.01);
    EXPECT_NEAR(model.viscosity_moment, 0.708, 0.01);
  }
}

TEST(MakeModelTest, DomainBoundsAreRoundedToFloat) {
  Scene scene = ParseScene(R"({"domain": {"min": [-1.1, -0.3, 0], "max": [0.9, 0.7, 1.3]},
                               "fluid_blocks": [{"size": 0.5, "particles_per_axis": 2}]})");
  const Model model = MakeModel(scene, scene.params);
  for (int a = 0; a < 3; ++a) {
    SCOPED_TRACE(a);
    EXPECT_EQ(model.domain.min[a], double(float(scene.domain.min[a])));
    EXPECT_EQ(model.domain.max[a], double(float(scene.domain.max[a])));
  }
  // -1.1 has no exact float: the model's floor is float(-1.1), just below the scene's.
  EXPECT_NE(model.domain.min.x(), -1.1);
  EXPECT_LT(model.domain.min.x(), -1.1);
  EXPECT_EQ(model.domain.min.z(), 0.0);
}

TEST(MakeModelTest, NoSlipIsOffOnPeriodicAxes) {
  Scene scene = ParseScene(R"({"domain": {"min": [0, 0, 0], "max": [2, 2, 2],
                                          "periodic": [true, false, false],
                                          "no_slip": [false, true, true]},
                               "fluid_blocks": [{"center": [1, 1, 1], "size": 0.5,
                                                 "particles_per_axis": 2}]})");
  Model model = MakeModel(scene, scene.params);
  EXPECT_EQ(model.periodic, (Periodicity{true, false, false}));
  EXPECT_EQ(model.no_slip, (std::array<bool, 3>{false, true, true}));
  EXPECT_TRUE(model.HasNoSlipWalls());
  // A no-slip flag on a periodic axis is dropped: that axis has no walls.
  scene.no_slip = {true, false, false};
  model = MakeModel(scene, scene.params);
  EXPECT_EQ(model.no_slip, (std::array<bool, 3>{false, false, false}));
  EXPECT_FALSE(model.HasNoSlipWalls());
}

TEST(MakeModelTest, APeriodicDomainTooShortForTheKernelThrowsNamingTheParameter) {
  // Seed: the support is smoothing_radius; the 1.2 m period needs at most 0.4 m.
  Scene scene = ParseScene(R"({"domain": {"min": [0, 0, 0], "max": [1.2, 1.2, 1.2],
                                          "periodic": [false, true, false]},
                               "fluid_blocks": [{"center": [0.6, 0.6, 0.6], "size": 0.4,
                                                 "particles_per_axis": 2}]})");
  EXPECT_NO_THROW(MakeModel(scene, scene.params));
  Params params = scene.params;
  params.smoothing_radius = 0.5;
  try {
    MakeModel(scene, params);
    ADD_FAILURE() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.field(), "smoothing_radius");
    EXPECT_NE(e.message().find("periodic in y"), std::string::npos) << e.what();
  }
  // A physical solver: the support is 2 particle_spacing; the same period allows at most 0.2 m.
  scene.solver = "wcsph";
  params = scene.params;
  params.particle_spacing = 0.1;
  EXPECT_NO_THROW(MakeModel(scene, params));
  params.particle_spacing = 0.25;
  try {
    MakeModel(scene, params);
    ADD_FAILURE() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.field(), "particle_spacing");
  }
}

}  // namespace
}  // namespace dysa
