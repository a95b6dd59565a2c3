#include "dysa/core/model.h"

namespace dysa {

Model MakeModel(const Scene& scene, const Params& params) {
  Model model;
  model.params = params;
  // The walls clamp float positions to float(bound); with the bounds themselves rounded to float
  // a particle resting on a wall is inside the domain in double arithmetic too (probes).
  model.domain.min = scene.domain.min.cast<Real>().cast<double>();
  model.domain.max = scene.domain.max.cast<Real>().cast<double>();
  model.spheres = scene.spheres;
  model.boxes = scene.boxes;
  model.dt = params.time_scale / (params.frame_rate * params.iterations_per_frame);
  return model;
}

}  // namespace dysa
