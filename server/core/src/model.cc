#include "dysa/core/model.h"

#include <algorithm>

#include "dysa/core/kernels.h"
#include "dysa/core/solver.h"

namespace dysa {

Model MakeModel(const Scene& scene, const Params& params, const SolverInfo& solver) {
  CheckPeriodicDomain(scene, params);
  Model model;
  model.params = params;
  model.periodic = scene.periodic;
  for (int a = 0; a < 3; ++a) model.no_slip[a] = scene.no_slip[a] && !scene.periodic[a];
  // The walls clamp float positions to float(bound); with the bounds themselves rounded to float
  // a particle resting on a wall is inside the domain in double arithmetic too (probes).
  model.domain.min = scene.domain.min.cast<Real>().cast<double>();
  model.domain.max = scene.domain.max.cast<Real>().cast<double>();
  model.spheres = scene.spheres;
  model.boxes = scene.boxes;
  model.dt = params.time_scale / (params.frame_rate * params.iterations_per_frame);
  model.physical = solver.physical;
  if (model.physical) {
    const double d = params.particle_spacing;
    model.particle_mass = params.rest_density * d * d * d;
    model.kernel_kind = KernelKind(params.kernel);
    model.kernel_support = 2 * params.smoothing_length_ratio * d;
    model.grid_cells_per_support = params.grid_cells_per_support;
    model.gradient_moment = LatticeGradientMoment(model.Kernel<double>(), d);
    model.viscosity_moment = LatticeViscosityMoment(model.Kernel<double>(), d);
    // Only a kernel sum above 1 is corrected: it reads as compression, which both solvers act
    // on; one below 1 (the cubic spline at 2 d: 0.99997) leaves the rest lattice a hair under
    // rho0, which wcsph's clamp at rho0 and dfsph's compression-only solve leave alone, and
    // correcting it put dfsph's channel exactly at rho0, where float noise starts solves.
    model.density_moment = std::max(1.0, LatticeDensityMoment(model.Kernel<double>(), d));
  } else {
    model.particle_mass = params.particle_mass;
    model.kernel_support = params.smoothing_radius;
  }
  return model;
}

Model MakeModel(const Scene& scene, const Params& params) {
  return MakeModel(scene, params, FindSolver(scene.solver));
}

}  // namespace dysa
