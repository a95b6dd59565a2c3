// Tests of viewer/src/obstacle_placement.cc: the instance data the renderer draws the obstacles
// from, at a frame's simulated time.
#include "obstacle_placement.h"

#include <gtest/gtest.h>

#include <vector>

namespace dysa::viewer {
namespace {

remote::SceneDescription MovingScene() {
  remote::SceneDescription scene;
  remote::SphereObstacle sphere;
  sphere.center = {1, 2, 3};
  sphere.radius = 0.5;
  // 1.5 m/s along y over [0.1, 0.5] s.
  sphere.motion.keys = {{0.1, {0, 0, 0}}, {0.5, {0, 0.6, 0}}};
  scene.spheres.push_back(sphere);
  remote::BoxObstacle still;
  still.min = {-1, -1, -1};
  still.max = {0, 0, 0};
  scene.boxes.push_back(still);
  remote::BoxObstacle path;
  path.min = {2, 0, 0};
  path.max = {3, 1, 2};
  path.motion.keys = {{0, {0, 0, 0}}, {0.2, {1, 0, 0.5}}, {0.4, {-1, 0, 0}}};
  scene.boxes.push_back(path);
  return scene;
}

TEST(ObstaclePlacementTest, ObstaclesAreDrawnWhereTheirMotionHasThemAtTheFramesTime) {
  const remote::SceneDescription scene = MovingScene();
  EXPECT_TRUE(AnyObstacleMoves(scene));
  // Before the sphere starts, at the scene's positions.
  EXPECT_EQ(SphereInstances(scene.spheres, 0.0), (std::vector<float>{1, 2, 3, 0.5f}));
  EXPECT_EQ(SphereInstances(scene.spheres, 0.3), (std::vector<float>{1, 2.3f, 3, 0.5f}));
  EXPECT_EQ(SphereInstances(scene.spheres, 7.0), (std::vector<float>{1, 2.6f, 3, 0.5f}));

  // The static box stays; the other is halfway along its first segment at 0.1 s.
  EXPECT_EQ(BoxInstances(scene.boxes, 0.1),
            (std::vector<float>{-1, -1, -1, 0, 0, 0, 2.5f, 0, 0.25f, 3.5f, 1, 2.25f}));
  // The same time gives the same place, however it was reached (step back, reset).
  const std::vector<float> at_reset = BoxInstances(scene.boxes, 0.0);
  EXPECT_NE(BoxInstances(scene.boxes, 0.3), at_reset);
  EXPECT_EQ(BoxInstances(scene.boxes, 0.0), at_reset);
  EXPECT_EQ(at_reset, (std::vector<float>{-1, -1, -1, 0, 0, 0, 2, 0, 0, 3, 1, 2}));
}

TEST(ObstaclePlacementTest, AStaticSceneDoesNotMove) {
  remote::SceneDescription scene = MovingScene();
  scene.spheres[0].motion.keys.clear();
  scene.boxes[1].motion.keys.clear();
  EXPECT_FALSE(AnyObstacleMoves(scene));
  EXPECT_EQ(BoxInstances(scene.boxes, 0.3), BoxInstances(scene.boxes, 0.0));
  EXPECT_TRUE(SphereInstances({}, 1.0).empty());
}

}  // namespace
}  // namespace dysa::viewer
