#include "dysa/core/model.h"

namespace dysa {

Model MakeModel(const Scene& scene, const Params& params) {
  Model model;
  model.params = params;
  model.domain = scene.domain;
  model.spheres = scene.spheres;
  model.boxes = scene.boxes;
  model.dt = params.time_scale / (params.frame_rate * params.iterations_per_frame);
  return model;
}

}  // namespace dysa
