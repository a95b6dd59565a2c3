// Tests of dysa/core/scene.h: the built-in scenes hold the thesis's values, and every kind of bad
// scene is rejected with a ConfigError whose field() is the exact JSON path of the mistake.
#include "dysa/core/scene.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>

#include "dysa/core/params.h"
#include "dysa/core/types.h"

namespace dysa {
namespace {

using ::testing::HasSubstr;

// Parses `json`, expects a ConfigError, checks its field() and returns it.
ConfigError ExpectConfigError(std::string_view json, std::string_view field) {
  SCOPED_TRACE(std::string(json));
  try {
    ParseScene(json);
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.field(), field) << "what(): " << e.what();
    if (!field.empty()) {
      EXPECT_THAT(e.what(), HasSubstr(std::string(field)));
    }
    return e;
  } catch (const std::exception& e) {
    ADD_FAILURE() << "expected a ConfigError naming " << field
                  << ", got another exception: " << e.what();
    return ConfigError("", "");
  }
  ADD_FAILURE() << "expected a ConfigError naming " << field << ", but the scene parsed";
  return ConfigError("", "");
}

TEST(BuiltinScenesTest, EveryBuiltinSceneParses) {
  const std::vector<std::string> names = BuiltinSceneNames();
  ASSERT_EQ(names.size(), BuiltinSceneTexts().size());
  for (const char* expected : {"seed_basic", "seed_test_scene", "seed_obstacles"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), expected), names.end()) << expected;
  }
  for (const std::string& name : names) {
    SCOPED_TRACE(name);
    Scene scene;
    ASSERT_NO_THROW(scene = LoadScene(name));
    EXPECT_EQ(scene.name, name);
    EXPECT_FALSE(scene.description.empty());
    EXPECT_FALSE(scene.fluid_blocks.empty());
    EXPECT_NO_THROW(BlockParticleCounts(scene, scene.params));
    for (int a = 0; a < 3; ++a) EXPECT_LT(scene.domain.min[a], scene.domain.max[a]);
  }
}

TEST(BuiltinScenesTest, SeedTestSceneHasTheThesisValues) {
  const Scene scene = LoadScene("seed_test_scene");
  const Params& p = scene.params;
  EXPECT_EQ(scene.solver, "seed");
  EXPECT_EQ(scene.domain.Size(), Vec3d(10, 10, 10));
  EXPECT_EQ(scene.domain.Center(), Vec3d(0, 0, 0));
  EXPECT_EQ(p.particle_quantity, 45);
  EXPECT_EQ(p.spawn_size, 5);
  EXPECT_EQ(p.spawn_jitter, 0.32);
  EXPECT_EQ(p.time_scale, 0.8);
  EXPECT_EQ(p.iterations_per_frame, 2);
  EXPECT_EQ(p.frame_rate, 60);
  EXPECT_EQ(p.smoothing_radius, 0.3);
  EXPECT_EQ(p.target_density, 630);
  EXPECT_EQ(p.pressure_multiplier, 58.8);
  EXPECT_EQ(p.near_pressure_multiplier, 28.88);
  EXPECT_EQ(p.viscosity, 0.001);
  EXPECT_EQ(p.collision_damping, 0.118);
  EXPECT_EQ(p.gravity, -10);
  EXPECT_EQ(p.particle_mass, 1);
  const std::vector<Eigen::Vector3i> counts = BlockParticleCounts(scene, p);
  ASSERT_EQ(counts.size(), 1u);
  EXPECT_EQ(counts[0], Eigen::Vector3i(45, 45, 45));
  EXPECT_EQ(int64_t{counts[0].prod()}, 91'125);
}

TEST(BuiltinScenesTest, SeedBasicHasTheThesisValues) {
  const Scene scene = LoadScene("seed_basic");
  const Params& p = scene.params;
  EXPECT_EQ(scene.domain.Size(), Vec3d(10, 6, 10));
  EXPECT_EQ(p.particle_quantity, 30);
  EXPECT_EQ(p.spawn_size, 5);
  EXPECT_EQ(p.spawn_jitter, 0.035);
  EXPECT_EQ(p.smoothing_radius, 0.2);
  EXPECT_EQ(p.target_density, 630);
  EXPECT_EQ(p.pressure_multiplier, 28.8);
  EXPECT_EQ(p.near_pressure_multiplier, 2.25);
  EXPECT_EQ(p.viscosity, 0.001);
  EXPECT_EQ(p.collision_damping, 0.086);
  EXPECT_EQ(p.gravity, -10);
  const std::vector<Eigen::Vector3i> counts = BlockParticleCounts(scene, p);
  ASSERT_EQ(counts.size(), 1u);
  EXPECT_EQ(counts[0], Eigen::Vector3i(30, 30, 30));
  // params.h: the defaults are the thesis's basic scene.
  const Params defaults;
  for (const ParamDecl& decl : ParamTable()) {
    EXPECT_EQ(decl.get(p), decl.get(defaults)) << decl.name;
  }
}

TEST(BuiltinScenesTest, SeedObstaclesHasASphereAndABox) {
  const Scene scene = LoadScene("seed_obstacles");
  ASSERT_EQ(scene.spheres.size(), 1u);
  ASSERT_EQ(scene.boxes.size(), 1u);
  EXPECT_GT(scene.spheres[0].radius, 0);
  EXPECT_TRUE(scene.domain.Contains(scene.spheres[0].center));
  for (int a = 0; a < 3; ++a) EXPECT_LT(scene.boxes[0].box.min[a], scene.boxes[0].box.max[a]);
  EXPECT_TRUE(scene.domain.Contains(scene.boxes[0].box.Center()));
  ASSERT_EQ(scene.fluid_blocks.size(), 1u);
  EXPECT_GT(scene.fluid_blocks[0].velocity.x(), 0);  // thrown at the obstacles
}

TEST(ParseSceneTest, EmptyObjectGivesTheDefaults) {
  const Scene scene = ParseScene("{}");
  EXPECT_EQ(scene.solver, "seed");
  ASSERT_EQ(scene.fluid_blocks.size(), 1u);  // the thesis's spawn cube
  EXPECT_FALSE(scene.fluid_blocks[0].particles_per_axis);
  EXPECT_FALSE(scene.fluid_blocks[0].spacing);
  EXPECT_TRUE(scene.spheres.empty());
  EXPECT_TRUE(scene.boxes.empty());
  EXPECT_TRUE(scene.probes.empty());
  const Params defaults;
  for (const ParamDecl& decl : ParamTable()) {
    EXPECT_EQ(decl.get(scene.params), decl.get(defaults)) << decl.name;
  }
}

TEST(ParseSceneTest, ReadsEveryField) {
  const Scene scene = ParseScene(R"({
    "name": "n", "description": "d",
    "domain": {"min": [-1, -2, -3], "max": [1, 2, 3]},
    "fluid_blocks": [
      {"center": [0.1, 0.2, 0.3], "size": [1, 0.5, 0.25], "particles_per_axis": [4, 5, 6],
       "jitter": 0.01, "seed": 9, "velocity": [1, -2, 3]},
      {"size": 0.6, "spacing": 0.1},
      {"particles_per_axis": 3}
    ],
    "obstacles": [{"type": "sphere", "center": [0, 1, 0], "radius": 0.3},
                  {"type": "box", "center": [0, -1, 0], "size": [0.2, 0.4, 0.6]}],
    "params": {"viscosity": 0.5, "particle_quantity": 7},
    "end_time": 2.5, "probe_interval": 0.1,
    "probes": [{"type": "front", "name": "fz", "axis": "z"},
               {"type": "height", "name": "h", "point": [0.5, 0, 0.5], "radius": 0.2,
                "gap": 0.05},
               {"type": "pressure", "name": "p", "point": [0, -1, 0]},
               {"type": "density", "name": "rho"},
               {"type": "kinetic_energy"},
               {"type": "count_inside", "name": "c",
                "region": {"min": [0, 0, 0], "max": [1, 1, 1]}},
               {"type": "wall_pressure", "name": "P1", "point": [0.8, 0.02, 0.4],
                "normal": [1, 0, 0]},
               {"type": "wall_pressure", "name": "P0", "point": [0, 0.5, 0]}]
  })");
  EXPECT_EQ(scene.name, "n");
  EXPECT_EQ(scene.description, "d");
  EXPECT_EQ(scene.domain.min, Vec3d(-1, -2, -3));
  EXPECT_EQ(scene.domain.max, Vec3d(1, 2, 3));
  ASSERT_EQ(scene.fluid_blocks.size(), 3u);
  const FluidBlock& b = scene.fluid_blocks[0];
  EXPECT_EQ(*b.center, Vec3d(0.1, 0.2, 0.3));
  EXPECT_EQ(*b.size, Vec3d(1, 0.5, 0.25));
  EXPECT_EQ(*b.particles_per_axis, Eigen::Vector3i(4, 5, 6));
  EXPECT_EQ(*b.jitter, 0.01);
  EXPECT_EQ(b.seed, 9u);
  EXPECT_EQ(b.velocity, Vec3d(1, -2, 3));
  EXPECT_EQ(*scene.fluid_blocks[1].size, Vec3d::Constant(0.6));
  EXPECT_EQ(*scene.fluid_blocks[1].spacing, 0.1);
  EXPECT_EQ(*scene.fluid_blocks[2].particles_per_axis, Eigen::Vector3i(3, 3, 3));
  ASSERT_EQ(scene.spheres.size(), 1u);
  EXPECT_EQ(scene.spheres[0].center, Vec3d(0, 1, 0));
  EXPECT_EQ(scene.spheres[0].radius, 0.3);
  ASSERT_EQ(scene.boxes.size(), 1u);
  EXPECT_TRUE(scene.boxes[0].box.min.isApprox(Vec3d(-0.1, -1.2, -0.3)));
  EXPECT_TRUE(scene.boxes[0].box.max.isApprox(Vec3d(0.1, -0.8, 0.3)));
  EXPECT_EQ(scene.params.viscosity, 0.5);
  EXPECT_EQ(scene.params.particle_quantity, 7);
  EXPECT_EQ(scene.end_time, 2.5);
  EXPECT_EQ(*scene.probe_interval, 0.1);
  ASSERT_EQ(scene.probes.size(), 8u);
  EXPECT_EQ(scene.probes[0].kind, ProbeKind::kFront);
  EXPECT_EQ(scene.probes[0].axis, 2);
  EXPECT_EQ(scene.probes[1].kind, ProbeKind::kHeight);
  EXPECT_EQ(scene.probes[1].point, Vec3d(0.5, 0, 0.5));
  EXPECT_EQ(scene.probes[1].radius, 0.2);
  EXPECT_EQ(scene.probes[1].gap, 0.05);
  EXPECT_EQ(scene.probes[2].kind, ProbeKind::kPressure);
  EXPECT_EQ(scene.probes[3].kind, ProbeKind::kDensity);
  EXPECT_EQ(scene.probes[4].kind, ProbeKind::kKineticEnergy);
  EXPECT_EQ(scene.probes[4].name, "kinetic_energy");  // the type is the default name
  EXPECT_EQ(scene.probes[5].kind, ProbeKind::kCountInside);
  ASSERT_TRUE(scene.probes[5].region);
  EXPECT_EQ(scene.probes[5].region->max, Vec3d(1, 1, 1));
  EXPECT_EQ(scene.probes[6].kind, ProbeKind::kWallPressure);
  EXPECT_EQ(scene.probes[6].point, Vec3d(0.8, 0.02, 0.4));
  EXPECT_EQ(scene.probes[6].normal, Vec3d(1, 0, 0));
  EXPECT_EQ(scene.probes[7].normal, Vec3d::Zero());  // no normal: every side counts

  const std::vector<Eigen::Vector3i> counts = BlockParticleCounts(scene, scene.params);
  ASSERT_EQ(counts.size(), 3u);
  EXPECT_EQ(counts[0], Eigen::Vector3i(4, 5, 6));
  EXPECT_EQ(counts[1], Eigen::Vector3i(6, 6, 6));  // 0.6 / 0.1 cells per axis
  EXPECT_EQ(counts[2], Eigen::Vector3i(3, 3, 3));
}

TEST(ParseSceneTest, BlockWithoutCountUsesParticleQuantity) {
  const Scene scene = ParseScene(R"({"params": {"particle_quantity": 11}})");
  Params p = scene.params;
  EXPECT_EQ(BlockParticleCounts(scene, p)[0], Eigen::Vector3i(11, 11, 11));
  p.particle_quantity = 4;
  EXPECT_EQ(BlockParticleCounts(scene, p)[0], Eigen::Vector3i(4, 4, 4));
}

TEST(ParseSceneTest, MalformedJsonMentionsLineAndColumn) {
  const ConfigError e = ExpectConfigError("{\n  \"name\": \"x\",\n  \"end_time\": ,\n}", "");
  EXPECT_THAT(e.what(), HasSubstr("line 3"));
  EXPECT_THAT(e.what(), HasSubstr("column"));
  ExpectConfigError("", "");
  ExpectConfigError("{\"name\": \"x\"", "");
}

TEST(ParseSceneTest, TopLevelMustBeAnObject) {
  ExpectConfigError("[]", "");
  ExpectConfigError("3", "");
}

TEST(ParseSceneTest, UnknownFieldsAreNamed) {
  EXPECT_THAT(ExpectConfigError(R"({"colour": "blue"})", "colour").what(),
              HasSubstr("fluid_blocks"));  // lists the allowed fields
  ExpectConfigError(R"({"fluid_blocks": [{"colour": "blue"}]})", "fluid_blocks[0].colour");
  ExpectConfigError(R"({"fluid_blocks": [{}, {"center": [0, 0, 0], "colour": 1}]})",
                    "fluid_blocks[1].colour");
  ExpectConfigError(R"({"domain": {"min": [0, 0, 0], "max": [1, 1, 1], "mid": 0}})", "domain.mid");
  ExpectConfigError(R"({"obstacles": [{"type": "sphere", "size": 1}]})", "obstacles[0].size");
  ExpectConfigError(R"({"probes": [{"type": "density", "point": [0, 0, 0]}]})", "probes[0].point");
  ExpectConfigError(
      R"({"probes": [{"type": "count_inside", "region": {"min": [0, 0, 0], "max": [1, 1, 1],
          "extra": 1}}]})",
      "probes[0].region.extra");
}

TEST(ParseSceneTest, WrongTypesAreNamed) {
  EXPECT_THAT(ExpectConfigError(R"({"end_time": "5"})", "end_time").what(), HasSubstr("string"));
  ExpectConfigError(R"({"name": 5})", "name");
  ExpectConfigError(R"({"domain": {"min": [0, 0], "max": [1, 1, 1]}})", "domain.min");
  ExpectConfigError(R"({"domain": {"min": [0, 0, 0, 0], "max": [1, 1, 1]}})", "domain.min");
  ExpectConfigError(R"({"domain": {"min": 0, "max": [1, 1, 1]}})", "domain.min");
  ExpectConfigError(R"({"domain": {"min": [0, "0", 0], "max": [1, 1, 1]}})", "domain.min[1]");
  ExpectConfigError(R"({"domain": {"max": [1, 1, 1]}})", "domain.min");
  ExpectConfigError(R"({"domain": []})", "domain");
  ExpectConfigError(R"({"fluid_blocks": {}})", "fluid_blocks");
  ExpectConfigError(R"({"fluid_blocks": [3]})", "fluid_blocks[0]");
  ExpectConfigError(R"({"fluid_blocks": [{"velocity": [1, 2]}]})", "fluid_blocks[0].velocity");
  ExpectConfigError(R"({"fluid_blocks": [{"jitter": "big"}]})", "fluid_blocks[0].jitter");
  ExpectConfigError(R"({"params": {"viscosity": "0.1"}})", "params.viscosity");
  ExpectConfigError(R"({"params": []})", "params");
  ExpectConfigError(R"({"solver": 3})", "solver");
}

TEST(ParseSceneTest, BadParticleCountsAreNamed) {
  for (const char* count : {"0", "-1", "-100", "2.5", "\"10\"", "true"}) {
    ExpectConfigError(std::string(R"({"fluid_blocks": [{"particles_per_axis": )") + count + "}]}",
                      "fluid_blocks[0].particles_per_axis");
  }
  ExpectConfigError(R"({"fluid_blocks": [{"particles_per_axis": [4, 0, 4]}]})",
                    "fluid_blocks[0].particles_per_axis[1]");
  ExpectConfigError(R"({"fluid_blocks": [{"particles_per_axis": [4, 4]}]})",
                    "fluid_blocks[0].particles_per_axis");
  ExpectConfigError(R"({"fluid_blocks": [{"spacing": 0}]})", "fluid_blocks[0].spacing");
  ExpectConfigError(R"({"fluid_blocks": [{"spacing": -0.1}]})", "fluid_blocks[0].spacing");
  ExpectConfigError(R"({"fluid_blocks": [{"size": 0}]})", "fluid_blocks[0].size");
  ExpectConfigError(R"({"fluid_blocks": [{"size": [1, -1, 1]}]})", "fluid_blocks[0].size[1]");
  ExpectConfigError(R"({"fluid_blocks": [{"jitter": -0.1}]})", "fluid_blocks[0].jitter");
}

TEST(ParseSceneTest, SpacingAndCountTogetherAreRejected) {
  ExpectConfigError(R"({"fluid_blocks": [{"particles_per_axis": 4, "spacing": 0.1}]})",
                    "fluid_blocks[0].spacing");
}

TEST(ParseSceneTest, DomainMaxMustExceedMin) {
  ExpectConfigError(R"({"domain": {"min": [0, 0, 0], "max": [1, 0, 1]}})", "domain.max");
  ExpectConfigError(R"({"domain": {"min": [0, 0, 0], "max": [1, 1, -1]}})", "domain.max");
  ExpectConfigError(
      R"({"probes": [{"type": "count_inside", "region": {"min": [2, 0, 0], "max": [1, 1, 1]}}]})",
      "probes[0].region.max");
}

TEST(ParseSceneTest, UnknownSolverIsNamed) {
  EXPECT_THAT(ExpectConfigError(R"({"solver": "magic"})", "solver").what(), HasSubstr("seed"));
}

TEST(ParseSceneTest, BadParametersAreNamed) {
  ExpectConfigError(R"({"params": {"foo": 1}})", "params.foo");
  const ConfigError e = ExpectConfigError(R"({"params": {"viscosity": -1}})", "params.viscosity");
  EXPECT_THAT(e.what(), HasSubstr(FindParam("viscosity")->RangeText()));
  ExpectConfigError(R"({"params": {"particle_quantity": 2.5}})", "params.particle_quantity");
  ExpectConfigError(R"({"params": {"particle_quantity": 501}})", "params.particle_quantity");
  ExpectConfigError(R"({"params": {"smoothing_radius": 0}})", "params.smoothing_radius");
}

TEST(ParseSceneTest, ParticleCountsThatWouldExhaustMemoryAreRejected) {
  // 3000^3 = 2.7e10 particles.
  ConfigError e =
      ExpectConfigError(R"({"fluid_blocks": [{"particles_per_axis": 3000}]})", "fluid_blocks[0]");
  EXPECT_THAT(e.what(), HasSubstr(std::to_string(kMaxParticles)));
  // The same through particle_quantity... which the parameter range already bounds (500^3 fits),
  // so through a spacing instead: 1000 cells per axis.
  ExpectConfigError(R"({"fluid_blocks": [{"size": 10, "spacing": 0.01}]})", "fluid_blocks[0]");
  // Two blocks each under the limit whose sum is over it: 2 x 700^3 = 6.9e8 > 5e8.
  e = ExpectConfigError(
      R"({"fluid_blocks": [{"particles_per_axis": 700}, {"particles_per_axis": 700}]})",
      "fluid_blocks[1]");
  EXPECT_THAT(e.what(), HasSubstr(std::to_string(kMaxParticles)));
  // Exactly at the limit is fine: 500 x 1000 x 1000 = 5e8 (at the smoothing radius's spacing,
  // 8 to a grid cell, not the default block's 5 m: ABlockCrowdingOneGridCellIsRefused).
  EXPECT_NO_THROW(ParseScene(
      R"({"fluid_blocks": [{"particles_per_axis": [500, 1000, 1000], "size": [99.8, 199.8, 199.8]}]})"));
  ExpectConfigError(R"({"fluid_blocks": [{"particles_per_axis": [500, 1000, 1001]}]})",
                    "fluid_blocks[0]");
}

TEST(ParseSceneTest, ParticleCountProductThatOverflowsIsRejected) {
  // 2^22 particles per axis from a spacing: 2^66 particles, which wraps to 0 in 64 bits. Each
  // axis alone is under kMaxParticles, so only the product can catch it.
  ExpectConfigError(R"({"fluid_blocks": [{"size": 4096, "spacing": 0.0009765625}]})",
                    "fluid_blocks[0]");
  // 2^21 x 2^21 x 2^22 = 2^64 as well.
  ExpectConfigError(R"({"fluid_blocks": [{"size": [2048, 2048, 4096], "spacing": 0.0009765625}]})",
                    "fluid_blocks[0]");
}

TEST(BlockParticleCountsTest, ChecksTheLimitWithTheGivenParams) {
  Scene scene = ParseScene(R"({"fluid_blocks": [{}, {}, {}, {}, {}, {}]})");
  Params p = scene.params;
  p.particle_quantity = 440;  // 6 x 8.5e7 = 5.1e8 > 5e8
  try {
    BlockParticleCounts(scene, p);
    FAIL() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.field(), "fluid_blocks[5]");
  }
  p.particle_quantity = 400;  // 6 x 6.4e7 = 3.8e8
  p.smoothing_radius = 0.02;  // 2.6 particles per grid cell edge, not 17
  EXPECT_EQ(BlockParticleCounts(scene, p).size(), 6u);
}

TEST(ParseSceneTest, BadProbesAreNamed) {
  ExpectConfigError(R"({"probes": [{"type": "temperature"}]})", "probes[0].type");
  ExpectConfigError(R"({"probes": [{"name": "x"}]})", "probes[0].type");
  ExpectConfigError(R"({"probes": [{"type": "front", "axis": "w"}]})", "probes[0].axis");
  ExpectConfigError(R"({"probes": [{"type": "density", "name": "a,b"}]})", "probes[0].name");
  ExpectConfigError(R"({"probes": [{"type": "density", "name": ""}]})", "probes[0].name");
  ExpectConfigError(R"({"probes": [{"type": "height", "radius": -1}]})", "probes[0].radius");
  ExpectConfigError(R"({"probes": [{"type": "height", "gap": -1}]})", "probes[0].gap");
  ExpectConfigError(R"({"probes": [{"type": "wall_pressure"}]})", "probes[0].point");
  ExpectConfigError(R"({"probes": [{"type": "wall_pressure", "point": [0, 0, 0], "normal": 1}]})",
                    "probes[0].normal");
  ExpectConfigError(R"({"probes": [{"type": "wall_pressure", "point": [0, 0, 0], "radius": 0.1}]})",
                    "probes[0].radius");
}

TEST(ParseSceneTest, ABoxForceProbeNamesItsBoxByItsPlaceAmongTheObstacles) {
  const Scene scene = ParseScene(R"({
    "obstacles": [{"type": "sphere", "center": [0, 0, 0], "radius": 0.2},
                  {"type": "box", "center": [1, 0, 0], "size": [0.5, 0.5, 0.5]},
                  {"type": "sphere", "center": [0, 1, 0], "radius": 0.2},
                  {"type": "box", "center": [-1, 0, 0], "size": [0.2, 0.2, 0.2]}],
    "probes": [{"type": "box_force", "name": "F", "obstacle": 3, "spacing": 0.01},
               {"type": "box_force", "name": "G", "obstacle": 1}]})");
  ASSERT_EQ(scene.probes.size(), 2u);
  EXPECT_EQ(scene.probes[0].kind, ProbeKind::kBoxForce);
  EXPECT_EQ(scene.probes[0].box, 1);  // the second box
  EXPECT_EQ(scene.probes[0].spacing, 0.01);
  EXPECT_EQ(scene.probes[1].box, 0);
  EXPECT_EQ(scene.probes[1].spacing, 0.0);  // the default: the kernel's support
  EXPECT_EQ(scene.boxes.at(1).box.Center(), Vec3d(-1, 0, 0));
}

TEST(ParseSceneTest, ABadBoxForceProbeIsNamed) {
  const std::string obstacles = R"("obstacles": [{"type": "sphere"}, {"type": "box"}])";
  const ConfigError none =
      ExpectConfigError(R"({"probes": [{"type": "box_force"}]})", "probes[0].obstacle");
  EXPECT_THAT(none.what(), HasSubstr("has none"));
  const ConfigError missing = ExpectConfigError(
      "{" + obstacles + R"(, "probes": [{"type": "box_force"}]})", "probes[0].obstacle");
  EXPECT_THAT(missing.what(), HasSubstr("[0, 1]"));
  const ConfigError sphere =
      ExpectConfigError("{" + obstacles + R"(, "probes": [{"type": "box_force", "obstacle": 0}]})",
                        "probes[0].obstacle");
  EXPECT_THAT(sphere.what(), HasSubstr("is a sphere"));
  ExpectConfigError("{" + obstacles + R"(, "probes": [{"type": "box_force", "obstacle": 2}]})",
                    "probes[0].obstacle");
  ExpectConfigError("{" + obstacles + R"(, "probes": [{"type": "box_force", "obstacle": 0.5}]})",
                    "probes[0].obstacle");
  ExpectConfigError(
      "{" + obstacles + R"(, "probes": [{"type": "box_force", "obstacle": 1, "spacing": 0}]})",
      "probes[0].spacing");
  ExpectConfigError(
      "{" + obstacles +
          R"(, "probes": [{"type": "box_force", "obstacle": 1, "point": [0, 0, 0]}]})",
      "probes[0].point");
}

TEST(ParseSceneTest, DuplicateProbeNamesAreRejected) {
  ExpectConfigError(R"({"probes": [{"type": "density", "name": "a"},
                                   {"type": "kinetic_energy", "name": "a"}]})",
                    "probes[1].name");
  // The default name is the type.
  ExpectConfigError(R"({"probes": [{"type": "kinetic_energy"}, {"type": "kinetic_energy"}]})",
                    "probes[1].name");
}

TEST(ParseSceneTest, BadObstaclesAreNamed) {
  ExpectConfigError(R"({"obstacles": [{"type": "cone"}]})", "obstacles[0].type");
  ExpectConfigError(R"({"obstacles": [{"type": "sphere", "radius": 0}]})", "obstacles[0].radius");
  ExpectConfigError(R"({"obstacles": [{"type": "box", "size": [1, 0, 1]}]})",
                    "obstacles[0].size[1]");
}

TEST(ParseSceneTest, OutOfRangeNumbersAreNamed) {
  ExpectConfigError(R"({"end_time": 0})", "end_time");
  ExpectConfigError(R"({"end_time": -1})", "end_time");
  ExpectConfigError(R"({"probe_interval": 0})", "probe_interval");
  ExpectConfigError(R"({"fluid_blocks": [{"velocity": [1e9, 0, 0]}]})",
                    "fluid_blocks[0].velocity[0]");
  ExpectConfigError(R"({"domain": {"min": [-1e300, 0, 0], "max": [1, 1, 1]}})", "domain.min[0]");
}

// json::parse throws out_of_range for 1e999, which escaped as "[json.exception.out_of_range.406]"
// (and UNIMPLEMENTED through LoadScene); 1e-400 silently became 0.
TEST(ParseSceneTest, NumbersADoubleCannotHoldAreNamedByTheirPath) {
  EXPECT_EQ(
      std::string(
          ExpectConfigError(R"({"params": {"viscosity": 1e999}})", "params.viscosity").what()),
      "params.viscosity: 1e999 is out of the range of a double (at most 1.8e308 in "
      "magnitude)");
  EXPECT_EQ(
      std::string(
          ExpectConfigError(R"({"params": {"viscosity": 1e-400}})", "params.viscosity").what()),
      "params.viscosity: 1e-400 is too close to 0 for a double (it would round to 0)");
  ExpectConfigError(R"({"fluid_blocks": [{}, {"size": [1, -1e999, 1]}]})",
                    "fluid_blocks[1].size[1]");
  ExpectConfigError(R"({"fluid_blocks": [{}, {"size": [1, -1e-999, 1]}]})",
                    "fluid_blocks[1].size[1]");
  ExpectConfigError(R"({"end_time": 1E400})", "end_time");
  ExpectConfigError(R"({"probes": [{"type": "height", "point": [0, 0, 7e-999]}]})",
                    "probes[0].point[2]");
  ExpectConfigError("1e999", "");
  // A 400,000-digit number is quoted, not copied.
  const std::string digits = "1" + std::string(400'000, '0');
  const ConfigError long_number =
      ExpectConfigError(R"({"params": {"gravity": )" + digits + "}}", "params.gravity");
  EXPECT_LT(std::string(long_number.what()).size(), 300u);
  EXPECT_THAT(long_number.what(), HasSubstr("(400001 bytes)"));
  // Zero written any way, and subnormals, are doubles.
  EXPECT_EQ(ParseScene(R"({"params": {"viscosity": 0e-999}})").params.viscosity, 0.0);
  EXPECT_EQ(ParseScene(R"({"params": {"viscosity": 0.000e5}})").params.viscosity, 0.0);
  EXPECT_GT(ParseScene(R"({"params": {"viscosity": 4.9e-324}})").params.viscosity, 0.0);
}

// Whatever the text, ParseScene throws a ConfigError with a bounded message, never another
// exception (nor a crash from the depth of the text).
TEST(ParseSceneTest, HostileTextGivesABoundedConfigErrorOnly) {
  const std::string huge(3'900'000, 'k');
  const std::vector<std::string> texts = {
      "{\"name\": \"a\xff\"}",                                // not UTF-8
      "{\"name\": \"a\x01\"}",                                // an unescaped control character
      R"({"name": "\ud800"})",                                // a lone surrogate
      std::string(100'000, '['),                              // unbalanced, deep
      std::string(100'000, '[') + std::string(100'000, ']'),  // balanced, deep
      "{\"" + huge + "\": 1}",                                // a huge unknown field
      "{\"params\": {\"" + huge + "\": 1}}",                  // a huge unknown parameter
      "{\"name\": \"" + huge + "\x02\"}",                     // a huge string the lexer refuses
      "{\"end_time\": t" + huge + "}",                        // a huge invalid literal
      "{\"solver\": \"" + huge + "\"}",                       // a huge unknown solver
      "{\"obstacles\": [{\"type\": \"" + huge + "\"}]}",
      "{\"probes\": [{\"type\": \"" + huge + "\"}]}",
      "{\"probes\": [{\"type\": \"front\", \"axis\": \"" + huge + "\"}]}",
  };
  for (const std::string& text : texts) {
    SCOPED_TRACE(text.substr(0, 40));
    try {
      ParseScene(text);
      ADD_FAILURE() << "parsed";
    } catch (const ConfigError& e) {
      EXPECT_LT(std::string(e.what()).size(), 1000u) << std::string(e.what()).substr(0, 2000);
    } catch (const std::exception& e) {
      ADD_FAILURE() << "not a ConfigError: " << std::string(e.what()).substr(0, 200);
    }
  }
  // The root, fluid_blocks and its block are 3 levels: the 30th array of size is the 33rd.
  std::string deep_path = "fluid_blocks[0].size";
  for (int level = 4; level <= 32; ++level) deep_path += "[0]";
  const ConfigError deep =
      ExpectConfigError(R"({"fluid_blocks": [{"size": )" + std::string(40, '[') + "}]}", deep_path);
  EXPECT_THAT(deep.what(), HasSubstr("nested deeper than 32 levels"));
}

TEST(ParseSceneTest, ClientTextInMessagesIsEscaped) {
  EXPECT_THAT(ExpectConfigError(R"({"col\nour\u001b[2J": 1})", "col\\nour\\x1b[2J").what(),
              HasSubstr("unknown field"));
  ExpectConfigError(R"({"params": {"visc\u0000osity": 1}})", "params.visc\\x00osity");
  EXPECT_THAT(ExpectConfigError(R"({"solver": "se\ned"})", "solver").what(),
              HasSubstr("unknown solver \"se\\ned\""));
  EXPECT_THAT(
      ExpectConfigError(R"({"obstacles": [{"type": "co\rne"}]})", "obstacles[0].type").what(),
      HasSubstr("got \"co\\rne\""));
  EXPECT_THAT(
      ExpectConfigError(R"({"probes": [{"type": "front", "axis": "\u009b"}]})", "probes[0].axis")
          .what(),
      HasSubstr("got \"\\u009b\""));
}

// A name and a description are kept by a server and sent in every status reply: bounded, and
// without control characters that would forge log lines or drive a terminal.
TEST(ParseSceneTest, NamesAndDescriptionsAreBoundedAndPrintable) {
  const std::string name(kMaxSceneNameBytes, 'n');
  EXPECT_EQ(ParseScene(R"({"name": ")" + name + "\"}").name, name);
  EXPECT_EQ(std::string(ExpectConfigError(R"({"name": ")" + name + "n\"}", "name").what()),
            "name: at most 256 bytes; got 257");
  EXPECT_THAT(ExpectConfigError(R"({"name": "a\nb"})", "name").what(),
              HasSubstr("control characters are not allowed; got \"a\\nb\""));
  ExpectConfigError(R"({"name": "a\u001b[31m"})", "name");
  ExpectConfigError(R"({"name": "\u0085"})", "name");
  EXPECT_EQ(ParseScene(R"({"name": "Stau\u00dfe \u6c34"})").name,
            "Stau\xc3\x9f"
            "e \xe6\xb0\xb4");

  const std::string description(kMaxSceneDescriptionBytes - 2, 'd');
  EXPECT_EQ(ParseScene(R"({"description": "\t)" + description + R"(\n"})").description,
            "\t" + description + "\n");
  EXPECT_EQ(
      std::string(
          ExpectConfigError(R"({"description": ")" + description + "ddd\"}", "description").what()),
      "description: at most 4096 bytes; got 4097");
  EXPECT_THAT(ExpectConfigError(R"({"description": "a\u001b[2J"})", "description").what(),
              HasSubstr("control characters other than newlines and tabs are not allowed"));

  EXPECT_EQ(
      ParseScene(R"({"probes": [{"type": "density", "name": ")" + name + "\"}]}").probes[0].name,
      name);
  ExpectConfigError(R"({"probes": [{"type": "density", "name": ")" + name + "n\"}]}",
                    "probes[0].name");
  ExpectConfigError(R"({"probes": [{"type": "density", "name": "a\tb"}]})", "probes[0].name");
}

TEST(ParseSceneTest, ObstaclesAreBounded) {
  std::string obstacles;
  for (size_t i = 0; i < kMaxObstacles; ++i) {
    obstacles += std::string(i ? "," : "") + R"({"type": "sphere", "radius": 0.1})";
  }
  EXPECT_EQ(ParseScene(R"({"obstacles": [)" + obstacles + "]}").spheres.size(), kMaxObstacles);
  EXPECT_EQ(
      std::string(ExpectConfigError(R"({"obstacles": [)" + obstacles + R"(, {"type": "box"}]})",
                                    "obstacles")
                      .what()),
      "obstacles: at most 10000 obstacles; got 10001");
}

class TempFile {
 public:
  explicit TempFile(const std::string& name, const std::string& text)
      : path_(std::filesystem::path(::testing::TempDir()) /
              (std::to_string(::getpid()) + "_" + name)) {
    std::ofstream(path_) << text;
  }
  ~TempFile() { std::filesystem::remove(path_); }
  std::string path() const { return path_.string(); }

 private:
  std::filesystem::path path_;
};

// A valid-looking block whose particles sit at one point (issue 21): every step would be
// O(n^2). Refused at load, naming the block and the limit; the same block spread out loads.
TEST(ParseSceneTest, ABlockCrowdingOneGridCellIsRefused) {
  try {
    ParseScene(R"({"fluid_blocks":[{"particles_per_axis":[200,200,1],"size":1e-6}]})");
    FAIL() << "accepted";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.field(), "fluid_blocks[0]");
    EXPECT_THAT(e.what(), ::testing::HasSubstr("would share one neighbour-grid cell"));
    EXPECT_THAT(e.what(), ::testing::HasSubstr("at most 1024"));
  }
  EXPECT_NO_THROW(ParseScene(R"({"fluid_blocks":[{"particles_per_axis":[200,200,1],"size":8}]})"));
  // Also when a parameter change would crowd the cells: a larger smoothing radius.
  Scene scene = ParseScene(R"({"fluid_blocks":[{"particles_per_axis":[40,40,40],"size":2}]})");
  Params wide = scene.params;
  SetParam(wide, "smoothing_radius", 1.0);
  EXPECT_THROW(BlockParticleCounts(scene, wide), ConfigError);
}

TEST(LoadSceneTest, MissingFileIsNamed) {
  const std::string path = "/nonexistent/dir/no_such_scene.json";
  try {
    LoadScene(path);
    FAIL() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr(path));
    EXPECT_THAT(e.what(), HasSubstr("seed_basic"));  // lists the built-in scenes
  }
  EXPECT_THROW(LoadScene("seed_basics"), ConfigError);
}

// A directory was reported as malformed JSON; a missing file as "neither a readable file nor a
// built-in scene".
TEST(LoadSceneTest, ADirectoryOrAMissingFileIsReportedAsSuch) {
  const std::string dir = ::testing::TempDir();
  try {
    LoadScene(dir);
    FAIL() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.field(), "scene");
    EXPECT_EQ(std::string(e.what()), "scene: '" + dir + "' is a directory, not a scene file");
  }
  try {
    LoadScene("/nonexistent/x.json");
    FAIL() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.field(), "scene");
    EXPECT_THAT(e.what(), HasSubstr("'/nonexistent/x.json': no such file, and no built-in scene"));
  }
}

// A device (or a pipe) has no size to check first: reading stops at the bound.
TEST(LoadSceneTest, AFileLargerThanTheBoundIsRefusedWhileReading) {
  try {
    LoadScene("/dev/zero");
    FAIL() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(std::string(e.what()),
              "scene: '/dev/zero' is larger than 64 MiB, the most a scene file may be");
  }
}

TEST(LoadSceneTest, ANameTakenFromTheFileIsMadePrintable) {
  TempFile file("a\nb\x1b.json", "{}");
  const Scene scene = LoadScene(file.path());
  EXPECT_EQ(scene.name, std::to_string(::getpid()) + "_a\\nb\\x1b");
}

TEST(LoadSceneTest, ReadsAFileAndNamesTheSceneAfterIt) {
  TempFile file("my_scene.json", R"({"params": {"viscosity": 0.2}})");
  const Scene scene = LoadScene(file.path());
  EXPECT_EQ(scene.params.viscosity, 0.2);
  EXPECT_EQ(scene.name, std::to_string(::getpid()) + "_my_scene");
}

TEST(LoadSceneTest, ErrorsInAFileNameTheFieldAndTheFile) {
  TempFile file("bad_scene.json", R"({"params": {"viscosity": -2}})");
  try {
    LoadScene(file.path());
    FAIL() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.field(), "params.viscosity");
    EXPECT_THAT(e.what(), HasSubstr(file.path()));
  }
}

// domain.periodic and domain.no_slip: one flag per axis; a periodic axis has no walls to grip,
// must hold 3 kernel supports (the seed's smoothing_radius, a physical solver's 2 d) and keeps
// obstacles a support away from its faces.
TEST(ParseSceneTest, PeriodicAndNoSlipAxes) {
  const Scene s = ParseScene(R"({
    "domain": {"min": [0, 0, 0], "max": [1, 1, 1], "periodic": [true, false, true],
               "no_slip": [false, true, false]}
  })");
  EXPECT_EQ(s.periodic, (Periodicity{true, false, true}));
  EXPECT_EQ(s.no_slip, (std::array<bool, 3>{false, true, false}));
  EXPECT_EQ(ParseScene("{}").periodic, (Periodicity{false, false, false}));
  ExpectConfigError(R"({"domain": {"min": [0, 0, 0], "max": [1, 1, 1], "periodic": true}})",
                    "domain.periodic");
  ExpectConfigError(R"({"domain": {"min": [0, 0, 0], "max": [1, 1, 1], "periodic": [1, 0, 0]}})",
                    "domain.periodic[0]");
  EXPECT_THAT(ExpectConfigError(R"({"domain": {"min": [0, 0, 0], "max": [1, 1, 1],
                                   "periodic": [false, true, false],
                                   "no_slip": [false, true, false]}})",
                                "domain.no_slip[1]")
                  .what(),
              HasSubstr("periodic"));
  // 0.5 m periodic in x: the seed's smoothing radius 0.2 would need 0.6 m.
  EXPECT_THAT(ExpectConfigError(R"({"domain": {"min": [0, 0, 0], "max": [0.5, 1, 1],
                                   "periodic": [true, false, false]},
                                   "fluid_blocks": [{"size": 0.2, "center": [0.25, 0.5, 0.5]}]})",
                                "smoothing_radius")
                  .what(),
              HasSubstr("at most 0.16666666666666666 m"));
  ExpectConfigError(R"({"domain": {"min": [0, 0, 0], "max": [1, 1, 1],
                       "periodic": [true, false, false]},
                       "obstacles": [{"type": "sphere", "center": [0.9, 0.5, 0.5], "radius": 0.05}]})",
                    "obstacles (sphere 0)");
  EXPECT_NO_THROW(ParseScene(R"({"domain": {"min": [0, 0, 0], "max": [1, 1, 1],
                               "periodic": [true, false, false]},
                               "obstacles": [{"type": "box", "center": [0.5, 0.5, 0.5],
                                              "size": 0.2}]})"));
}

// obstacles[i].motion: a constant velocity over [start, end], or keyframes; both become keys of a
// displacement that is linear between them and held before the first and after the last.
TEST(ObstacleMotionTest, VelocityOverAnIntervalBecomesTwoKeys) {
  const Scene s = ParseScene(R"({"obstacles": [
      {"type": "box", "center": [0, 0, 0], "size": 0.1,
       "motion": {"velocity": [0, 2, 0], "start": 0.5, "end": 1.5}},
      {"type": "sphere", "radius": 0.1}]})");
  ASSERT_EQ(s.boxes.size(), 1u);
  const ObstacleMotion& m = s.boxes[0].motion;
  EXPECT_TRUE(m.moving());
  EXPECT_FALSE(s.spheres[0].motion.moving());
  ASSERT_EQ(m.keys.size(), 2u);
  EXPECT_EQ(m.keys[0].time, 0.5);
  EXPECT_EQ(m.keys[1].displacement, Vec3d(0, 2, 0));
  EXPECT_EQ(m.DisplacementAt(0), Vec3d::Zero());
  EXPECT_EQ(m.DisplacementAt(0.5), Vec3d::Zero());
  EXPECT_NEAR(m.DisplacementAt(1.0).y(), 1.0, 1e-15);
  EXPECT_EQ(m.DisplacementAt(9), Vec3d(0, 2, 0));
  EXPECT_EQ(m.VelocityAt(0.2), Vec3d::Zero());
  EXPECT_EQ(m.VelocityAt(0.5), Vec3d(0, 2, 0));  // the segment that starts at the key
  EXPECT_EQ(m.VelocityAt(1.0), Vec3d(0, 2, 0));
  EXPECT_EQ(m.VelocityAt(1.5), Vec3d::Zero());
  // The scene's box stays where the scene put it: the motion is a displacement from there.
  EXPECT_EQ(s.boxes[0].box.min, Vec3d::Constant(-0.05));
  // start defaults to 0; end to the longest run (1e6 s): a push that never stops.
  const ObstacleMotion open = ParseScene(R"({"obstacles": [{"type": "sphere",
      "motion": {"velocity": [1, 0, 0]}}]})")
                                  .spheres[0]
                                  .motion;
  EXPECT_EQ(open.VelocityAt(0), Vec3d(1, 0, 0));
  EXPECT_EQ(open.VelocityAt(1e5), Vec3d(1, 0, 0));
}

TEST(ObstacleMotionTest, PathIsLinearBetweenKeysAndHeldOutside) {
  const ObstacleMotion m = ParseScene(R"({"obstacles": [{"type": "sphere",
      "motion": {"path": [[1, 0, 0, 0], [2, 0, 1, 0], [4, 0, 1, -1]]}}]})")
                               .spheres[0]
                               .motion;
  ASSERT_EQ(m.keys.size(), 3u);
  EXPECT_EQ(m.DisplacementAt(-1), Vec3d::Zero());
  EXPECT_EQ(m.DisplacementAt(1.5), Vec3d(0, 0.5, 0));
  EXPECT_EQ(m.DisplacementAt(2), Vec3d(0, 1, 0));
  EXPECT_EQ(m.DisplacementAt(3), Vec3d(0, 1, -0.5));
  EXPECT_EQ(m.DisplacementAt(5), Vec3d(0, 1, -1));
  EXPECT_EQ(m.VelocityAt(1.5), Vec3d(0, 1, 0));
  EXPECT_EQ(m.VelocityAt(3), Vec3d(0, 0, -0.5));
  EXPECT_EQ(m.VelocityAt(4), Vec3d::Zero());
  // One key: a fixed offset from the scene's position.
  const ObstacleMotion one =
      ParseScene(R"({"obstacles": [{"type": "box", "motion": {"path": [[0, 0.5, 0, 0]]}}]})")
          .boxes[0]
          .motion;
  EXPECT_EQ(one.DisplacementAt(0), Vec3d(0.5, 0, 0));
  EXPECT_EQ(one.VelocityAt(0), Vec3d::Zero());
  // No motion: static.
  EXPECT_EQ(ObstacleMotion{}.DisplacementAt(3), Vec3d::Zero());
  EXPECT_EQ(ObstacleMotion{}.VelocityAt(3), Vec3d::Zero());
}

TEST(ObstacleMotionTest, BadMotionsAreNamed) {
  auto obstacle = [](const std::string& motion) {
    return R"({"obstacles": [{"type": "box", "motion": )" + motion + "}]}";
  };
  ExpectConfigError(obstacle("[1, 0, 0]"), "obstacles[0].motion");
  ExpectConfigError(obstacle("{}"), "obstacles[0].motion.velocity");
  ExpectConfigError(obstacle(R"({"speed": 1})"), "obstacles[0].motion.speed");
  ExpectConfigError(obstacle(R"({"velocity": [1, 0]})"), "obstacles[0].motion.velocity");
  ExpectConfigError(obstacle(R"({"velocity": [1, 0, 1e5]})"), "obstacles[0].motion.velocity[2]");
  ExpectConfigError(obstacle(R"({"velocity": [1, 0, 0], "start": -1})"),
                    "obstacles[0].motion.start");
  EXPECT_THAT(ExpectConfigError(obstacle(R"({"velocity": [1, 0, 0], "start": 2, "end": 2})"),
                                "obstacles[0].motion.end")
                  .what(),
              HasSubstr("must exceed start"));
  ExpectConfigError(obstacle(R"({"velocity": [1, 0, 0], "end": 0})"), "obstacles[0].motion.end");
  ExpectConfigError(obstacle(R"({"velocity": [1, 0, 0], "path": [[0, 0, 0, 0]]})"),
                    "obstacles[0].motion.velocity");
  ExpectConfigError(obstacle(R"({"path": [[0, 0, 0, 0]], "end": 1})"), "obstacles[0].motion.end");
  ExpectConfigError(obstacle(R"({"path": []})"), "obstacles[0].motion.path");
  ExpectConfigError(obstacle(R"({"path": [0, 0, 0, 0]})"), "obstacles[0].motion.path[0]");
  ExpectConfigError(obstacle(R"({"path": [[0, 0, 0]]})"), "obstacles[0].motion.path[0]");
  ExpectConfigError(obstacle(R"({"path": [[0, 0, 0, "1"]]})"), "obstacles[0].motion.path[0][3]");
  ExpectConfigError(obstacle(R"({"path": [[-1, 0, 0, 0]]})"), "obstacles[0].motion.path[0][0]");
  ExpectConfigError(obstacle(R"({"path": [[0, 0, 2e6, 0]]})"), "obstacles[0].motion.path[0][2]");
  EXPECT_THAT(ExpectConfigError(obstacle(R"({"path": [[0, 0, 0, 0], [1, 1, 0, 0], [1, 2, 0, 0]]})"),
                                "obstacles[0].motion.path[2][0]")
                  .what(),
              HasSubstr("strictly increase"));
  // A number too large for a double is out of range, not infinite.
  ExpectConfigError(obstacle(R"({"path": [[1e999, 0, 0, 0]]})"), "obstacles[0].motion.path[0][0]");
  // Key counts: per obstacle, and in all.
  auto keys = [](size_t n) {
    std::string path = "{\"path\": [";
    for (size_t i = 0; i < n; ++i) path += (i ? ", [" : "[") + std::to_string(i) + ", 0, 0, 0]";
    return path + "]}";
  };
  EXPECT_NO_THROW(ParseScene(obstacle(keys(kMaxMotionKeys))));
  EXPECT_THAT(
      ExpectConfigError(obstacle(keys(kMaxMotionKeys + 1)), "obstacles[0].motion.path").what(),
      HasSubstr(std::to_string(kMaxMotionKeys)));
  std::string many = R"({"obstacles": [)";
  const size_t full = kMaxSceneMotionKeys / kMaxMotionKeys;
  for (size_t i = 0; i <= full; ++i) {
    many += std::string(i ? ", " : "") + R"({"type": "sphere", "motion": )" + keys(kMaxMotionKeys) +
            "}";
  }
  ExpectConfigError(many + "]}", "obstacles[" + std::to_string(full) + "].motion");
  // A sphere's motion is read as a box's.
  ExpectConfigError(R"({"obstacles": [{"type": "sphere", "motion": {"path": 1}}]})",
                    "obstacles[0].motion.path");
}

// An obstacle in a periodic domain must stay one support inside its faces along its whole path.
TEST(ObstacleMotionTest, PeriodicDomainChecksTheWholePath) {
  const std::string head = R"({"domain": {"min": [0, 0, 0], "max": [1, 1, 1],
      "periodic": [true, false, false]},
      "obstacles": [{"type": "box", "center": [0.5, 0.5, 0.5], "size": 0.2, "motion": )";
  EXPECT_NO_THROW(ParseScene(head + R"({"path": [[0, 0, 0, 0], [1, 0.05, 0, 0]]}}]})"));
  ExpectConfigError(head + R"({"path": [[0, 0, 0, 0], [1, 0.3, 0, 0]]}}]})", "obstacles (box 0)");
  ExpectConfigError(head + R"({"velocity": [-1, 0, 0], "end": 0.3}}]})", "obstacles (box 0)");
}

}  // namespace
}  // namespace dysa
