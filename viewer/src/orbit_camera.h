// An orbit camera: looks at a target point from a distance, turned by yaw and pitch. Mouse
// gestures map to Orbit (left drag), Pan (right or middle drag) and Zoom (scroll wheel).
// Plain maths, no OpenGL: tested in tests/viewer/orbit_camera_test.cc.
#pragma once

#include <Eigen/Core>

namespace dysa::viewer {

class OrbitCamera {
 public:
  // Frames the box [lo, hi] (m): looks at its centre, slightly from above and in front, from
  // far enough that the whole box is in view for a square viewport.
  void FitBox(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi);

  // Turns around the target by a mouse drag of (dx, dy) pixels. Pitch stays within +-89 degrees
  // so the view never flips over the pole.
  void Orbit(float dx_pixels, float dy_pixels);
  // Moves the target in the view plane so the point under the cursor follows the mouse:
  // one pixel is 2 d tan(fov/2) / height metres at the target's distance d.
  void Pan(float dx_pixels, float dy_pixels, float viewport_height_pixels);
  // Scroll steps: each step brings the camera 10% closer (negative: farther), within
  // [0.05, 20] times the fitted distance.
  void Zoom(float steps);

  Eigen::Vector3f Eye() const;  // camera position, m
  const Eigen::Vector3f& target() const { return target_; }
  float distance() const { return distance_; }
  float yaw() const { return yaw_; }      // radians about +y
  float pitch() const { return pitch_; }  // radians above the horizontal
  float fov_y() const { return fov_y_; }  // radians, vertical field of view

  // World to view (right-handed, looking down -z, +y up).
  Eigen::Matrix4f View() const;
  // OpenGL perspective projection with near and far planes that enclose the fitted scene at the
  // current distance.
  Eigen::Matrix4f Projection(float aspect) const;
  float near_plane() const;
  float far_plane() const;

 private:
  Eigen::Vector3f target_ = Eigen::Vector3f::Zero();
  float yaw_ = 0.6f;
  float pitch_ = 0.35f;
  float distance_ = 10.0f;
  float fitted_distance_ = 10.0f;
  float scene_radius_ = 5.0f;  // m, half the diagonal of the fitted box
  float fov_y_ = 0.7853982f;   // 45 degrees
};

}  // namespace dysa::viewer
