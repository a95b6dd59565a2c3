#include "orbit_camera.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace dysa::viewer {

namespace {
constexpr float kMaxPitch = 1.5533430f;  // 89 degrees
constexpr float kRadiansPerPixel = 0.006f;
}  // namespace

void OrbitCamera::FitBox(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi) {
  target_ = 0.5f * (lo + hi);
  scene_radius_ = std::max(0.5f * (hi - lo).norm(), 1e-3f);
  yaw_ = 0.6f;
  pitch_ = 0.35f;
  // The bounding sphere fits the vertical field of view, with a 10% margin.
  fitted_distance_ = 1.1f * scene_radius_ / std::sin(0.5f * fov_y_);
  distance_ = fitted_distance_;
}

void OrbitCamera::Orbit(float dx_pixels, float dy_pixels) {
  yaw_ -= dx_pixels * kRadiansPerPixel;
  yaw_ = std::remainder(yaw_, 2.0f * float(M_PI));
  pitch_ = std::clamp(pitch_ + dy_pixels * kRadiansPerPixel, -kMaxPitch, kMaxPitch);
}

void OrbitCamera::Pan(float dx_pixels, float dy_pixels, float viewport_height_pixels) {
  if (viewport_height_pixels <= 0) return;
  const float metres_per_pixel =
      2.0f * distance_ * std::tan(0.5f * fov_y_) / viewport_height_pixels;
  const Eigen::Matrix4f view = View();
  // Rows of the view rotation are the camera's right and up axes in world coordinates.
  const Eigen::Vector3f right = view.block<1, 3>(0, 0).transpose();
  const Eigen::Vector3f up = view.block<1, 3>(1, 0).transpose();
  // Dragging right moves the scene right: the target moves left. Screen y grows downwards.
  target_ += metres_per_pixel * (-dx_pixels * right + dy_pixels * up);
}

void OrbitCamera::Zoom(float steps) {
  distance_ *= std::pow(0.9f, steps);
  distance_ = std::clamp(distance_, 0.05f * fitted_distance_, 20.0f * fitted_distance_);
}

Eigen::Vector3f OrbitCamera::Eye() const {
  const Eigen::Vector3f offset(std::cos(pitch_) * std::sin(yaw_), std::sin(pitch_),
                               std::cos(pitch_) * std::cos(yaw_));
  return target_ + distance_ * offset;
}

Eigen::Matrix4f OrbitCamera::View() const {
  const Eigen::Vector3f eye = Eye();
  const Eigen::Vector3f forward = (target_ - eye).normalized();
  // |pitch| < 90 degrees, so forward is never parallel to +y.
  const Eigen::Vector3f right = forward.cross(Eigen::Vector3f::UnitY()).normalized();
  const Eigen::Vector3f up = right.cross(forward);
  Eigen::Matrix4f view = Eigen::Matrix4f::Identity();
  view.block<1, 3>(0, 0) = right.transpose();
  view.block<1, 3>(1, 0) = up.transpose();
  view.block<1, 3>(2, 0) = -forward.transpose();
  view(0, 3) = -right.dot(eye);
  view(1, 3) = -up.dot(eye);
  view(2, 3) = forward.dot(eye);
  return view;
}

float OrbitCamera::near_plane() const {
  return std::max(0.01f * scene_radius_, distance_ - 4.0f * scene_radius_);
}

float OrbitCamera::far_plane() const { return distance_ + 4.0f * scene_radius_; }

Eigen::Matrix4f OrbitCamera::Projection(float aspect) const {
  const float n = near_plane();
  const float f = far_plane();
  const float t = 1.0f / std::tan(0.5f * fov_y_);
  Eigen::Matrix4f p = Eigen::Matrix4f::Zero();
  p(0, 0) = t / std::max(aspect, 1e-6f);
  p(1, 1) = t;
  p(2, 2) = (f + n) / (n - f);
  p(2, 3) = 2.0f * f * n / (n - f);
  p(3, 2) = -1.0f;
  return p;
}

}  // namespace dysa::viewer
