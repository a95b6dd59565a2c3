#include "obstacle_placement.h"

#include <array>

namespace dysa::viewer {

bool AnyObstacleMoves(const remote::SceneDescription& scene) {
  for (const auto& s : scene.spheres) {
    if (s.motion.moving()) return true;
  }
  for (const auto& b : scene.boxes) {
    if (b.motion.moving()) return true;
  }
  return false;
}

std::vector<float> SphereInstances(const std::vector<remote::SphereObstacle>& spheres,
                                   double time) {
  std::vector<float> out;
  out.reserve(4 * spheres.size());
  for (const auto& s : spheres) {
    const std::array<double, 3> d = s.motion.DisplacementAt(time);
    out.insert(out.end(), {float(s.center[0] + d[0]), float(s.center[1] + d[1]),
                           float(s.center[2] + d[2]), float(s.radius)});
  }
  return out;
}

std::vector<float> BoxInstances(const std::vector<remote::BoxObstacle>& boxes, double time) {
  std::vector<float> out;
  out.reserve(6 * boxes.size());
  for (const auto& b : boxes) {
    const std::array<double, 3> d = b.motion.DisplacementAt(time);
    out.insert(out.end(), {float(b.min[0] + d[0]), float(b.min[1] + d[1]), float(b.min[2] + d[2]),
                           float(b.max[0] + d[0]), float(b.max[1] + d[1]), float(b.max[2] + d[2])});
  }
  return out;
}

}  // namespace dysa::viewer
