// The read-only side of a step: parameters and geometry. Passes take (const Model&, State&).
#pragma once

#include <vector>

#include "dysa/core/params.h"
#include "dysa/core/scene.h"
#include "dysa/core/types.h"

namespace dysa {

struct Model {
  Params params;
  Aabb domain;  // m; the walls of the box the fluid is kept in
  std::vector<SphereObstacle> spheres;
  std::vector<BoxObstacle> boxes;
  double dt = 0;  // s, the step: time_scale / (frame_rate * iterations_per_frame)

  bool HasObstacles() const { return !spheres.empty() || !boxes.empty(); }
};

Model MakeModel(const Scene& scene, const Params& params);

}  // namespace dysa
