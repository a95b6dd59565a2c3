// Tests of viewer/src/orbit_camera.cc: what the user sees when fitting, orbiting, panning and
// zooming, checked by projecting world points to the screen.
#include "orbit_camera.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

namespace dysa::viewer {
namespace {

// Normalised device coordinates of world point p (x, y in [-1, 1] when visible).
Eigen::Vector3f Project(const OrbitCamera& camera, const Eigen::Vector3f& p, float aspect = 1) {
  const Eigen::Vector4f clip = camera.Projection(aspect) * camera.View() * p.homogeneous();
  return clip.head<3>() / clip.w();
}

bool Visible(const Eigen::Vector3f& ndc) {
  return std::abs(ndc.x()) <= 1 && std::abs(ndc.y()) <= 1 && std::abs(ndc.z()) <= 1;
}

class OrbitCameraTest : public ::testing::Test {
 protected:
  OrbitCameraTest() { camera.FitBox(lo, hi); }
  const Eigen::Vector3f lo{-5, -3, -5};
  const Eigen::Vector3f hi{5, 3, 5};
  OrbitCamera camera;
};

TEST_F(OrbitCameraTest, FitBoxCentresTheBoxAndKeepsEveryCornerInView) {
  const Eigen::Vector3f centre = Project(camera, 0.5f * (lo + hi));
  EXPECT_NEAR(centre.x(), 0, 1e-5);
  EXPECT_NEAR(centre.y(), 0, 1e-5);
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3f corner((i & 1) ? hi.x() : lo.x(), (i & 2) ? hi.y() : lo.y(),
                                 (i & 4) ? hi.z() : lo.z());
    EXPECT_TRUE(Visible(Project(camera, corner))) << corner.transpose();
  }
}

TEST_F(OrbitCameraTest, ViewIsARigidMotionPlacingTheEyeAtTheOrigin) {
  const Eigen::Matrix4f view = camera.View();
  const Eigen::Matrix3f r = view.topLeftCorner<3, 3>();
  EXPECT_TRUE((r * r.transpose()).isIdentity(1e-5f));
  EXPECT_NEAR(r.determinant(), 1.0f, 1e-5f);
  const Eigen::Vector4f eye = view * camera.Eye().homogeneous();
  EXPECT_LT(eye.head<3>().norm(), 1e-4f);
  // The target lies straight ahead, down -z, at the camera's distance.
  const Eigen::Vector4f target = view * camera.target().homogeneous();
  EXPECT_NEAR(target.z(), -camera.distance(), 1e-4f);
  EXPECT_NEAR(target.x(), 0, 1e-4f);
  EXPECT_NEAR(target.y(), 0, 1e-4f);
}

TEST_F(OrbitCameraTest, OrbitKeepsTheDistanceAndNeverPassesThePoles) {
  const float d = camera.distance();
  camera.Orbit(300, 0);
  EXPECT_NEAR((camera.Eye() - camera.target()).norm(), d, 1e-3f);
  camera.Orbit(0, 1e6f);  // far past straight down
  EXPECT_LT(camera.pitch(), 1.5708f);
  EXPECT_GT(camera.pitch(), 1.5f);
  camera.Orbit(0, -1e6f);
  EXPECT_GT(camera.pitch(), -1.5708f);
  // Still a valid view looking at the target.
  EXPECT_TRUE(camera.View().allFinite());
  EXPECT_NEAR(Project(camera, camera.target()).x(), 0, 1e-4f);
}

TEST_F(OrbitCameraTest, PanMovesThePointUnderTheCursorWithTheMouse) {
  const float height = 800;
  const Eigen::Vector3f point = camera.target();
  const Eigen::Vector3f before = Project(camera, point);
  camera.Pan(100, 0, height);  // drag 100 pixels to the right
  const Eigen::Vector3f after = Project(camera, point);
  // 100 pixels of an 800-pixel-high square viewport are 0.25 in NDC.
  EXPECT_NEAR(after.x() - before.x(), 0.25f, 1e-3f);
  EXPECT_NEAR(after.y() - before.y(), 0, 1e-4f);
  camera.Pan(0, 80, height);  // drag down: the point moves down the screen (NDC y decreases)
  EXPECT_NEAR(Project(camera, point).y() - after.y(), -0.2f, 1e-3f);
}

TEST_F(OrbitCameraTest, ZoomApproachesAndIsBounded) {
  const float d = camera.distance();
  camera.Zoom(1);
  EXPECT_NEAR(camera.distance(), 0.9f * d, 1e-4f * d);
  camera.Zoom(-2);
  EXPECT_NEAR(camera.distance(), d / 0.9f, 1e-3f * d);
  camera.Zoom(1000);
  EXPECT_NEAR(camera.distance(), 0.05f * d, 1e-3f * d);
  camera.Zoom(-10000);
  EXPECT_NEAR(camera.distance(), 20.0f * d, 1e-2f * d);
}

TEST_F(OrbitCameraTest, ClipPlanesEncloseTheSceneAtEveryZoom) {
  for (float steps : {0.0f, 10.0f, 40.0f, -20.0f}) {
    camera.Zoom(steps);
    EXPECT_GT(camera.near_plane(), 0);
    EXPECT_LT(camera.near_plane(), camera.far_plane());
    // The far corner of the box lies before the far plane.
    const Eigen::Vector4f far_corner = camera.View() * Eigen::Vector3f(lo).homogeneous();
    EXPECT_LT(-far_corner.z(), camera.far_plane());
  }
}

}  // namespace
}  // namespace dysa::viewer
