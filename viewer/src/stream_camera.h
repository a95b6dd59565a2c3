// The viewer's camera as the server's view-dependent detail wants it (SetStreamView).
#pragma once

#include "dysa/client/types.h"
#include "orbit_camera.h"

namespace dysa::viewer {

// The orbit camera keeps +y up (its pitch stays within +-89 degrees).
inline remote::StreamCamera ToStreamCamera(const OrbitCamera& camera, float aspect) {
  const Eigen::Vector3f eye = camera.Eye();
  remote::StreamCamera out;
  out.eye = {eye.x(), eye.y(), eye.z()};
  out.target = {camera.target().x(), camera.target().y(), camera.target().z()};
  out.up = {0, 1, 0};
  out.fov_y_deg = double(camera.fov_y()) * 180.0 / 3.14159265358979323846;
  out.aspect = aspect;
  return out;
}

}  // namespace dysa::viewer
