// The host side the CUDA backends share (pipeline_backend.h).
#include "cuda/pipeline_backend.h"

#include <algorithm>
#include <vector>

#include "dysa/core/kernels.h"
#include "solvers/physical/boundary_particles.h"
#include "solvers/wcsph/becker_teschner_solver.h"

namespace dysa::cuda_backend {

cuda::GridLayout Layout(const NeighborGrid& grid) {
  cuda::GridLayout layout;
  for (int a = 0; a < 3; ++a) {
    layout.origin[a] = grid.origin()[a];
    layout.inv_cell[a] = grid.inv_cell_sizes()[a];
    layout.dims[a] = grid.dims()[a];
    layout.periodic[a] = grid.periodic()[a];
    layout.period[a] = grid.periods()[a];
  }
  layout.reach = grid.reach();
  return layout;
}

void AddObstacles(const Model& model, std::vector<cuda::SphereObstacle>& spheres,
                  std::vector<cuda::BoxObstacle>& boxes) {
  for (const SphereObstacle& s : model.spheres) {
    const Vec3 center = s.center.cast<Real>();
    spheres.push_back({{center.x(), center.y(), center.z()}, Real(s.radius)});
  }
  for (const BoxObstacle& b : model.boxes) {
    const Vec3 lo = b.box.min.cast<Real>(), hi = b.box.max.cast<Real>();
    boxes.push_back({{lo.x(), lo.y(), lo.z()}, {hi.x(), hi.y(), hi.z()}});
  }
}

// The fluid grid of the physical solvers (physical::SortIntoGrid's layout).
cuda::GridLayout PhysicalGrid(const Model& model) {
  NeighborGrid grid;
  grid.Configure(model.domain, Real(model.kernel_support), model.periodic,
                 model.grid_cells_per_support);
  return Layout(grid);
}

// The physical solvers' constants as their CPU passes compute them (becker_teschner_solver.cc,
// bender_koschier_solver.cc).
cuda::SphConstants PhysicalConstants(const Model& model) {
  const Params& prm = model.params;
  cuda::SphConstants c;
  const double rho0 = prm.rest_density;
  c.kernel = int(model.kernel_kind);
  c.support = Real(model.kernel_support);
  c.mass = Real(model.particle_mass);
  c.psi_scale = Real(rho0);
  c.density_scale = Real(1 / model.density_moment);
  c.gradient_scale = Real(1 / model.gradient_moment);
  c.viscosity_scale =
      Real(10 * prm.kinematic_viscosity * model.particle_mass / model.viscosity_moment);
  c.wall_viscosity_scale = Real(10 * prm.kinematic_viscosity / model.viscosity_moment);
  const Real h = Real(model.SmoothingLength());
  c.eps = Real(0.01) * h * h;
  c.rest_density = rho0;
  c.stiffness = rho0 * prm.speed_of_sound * prm.speed_of_sound / physical::kTaitExponent;
  c.contact_range = Real(prm.wall_contact_range * prm.particle_spacing);
  c.density_min = Real(rho0 * prm.carried_density_min);
  c.density_max = Real(rho0 * wcsph::kCarriedDensityMax);
  for (int a = 0; a < 3; ++a) {
    c.domain_lo[a] = Real(model.domain.min[a]);
    c.domain_hi[a] = Real(model.domain.max[a]);
  }
  return c;
}

// The move_boundary pass's table (physical::MoveBoundary): each obstacle's displacement and
// velocity at the step's start t; `fastest` the largest |u| (m/s), which the CFL step counts.
cuda::ObstacleMotionTable BoundaryMotion(const Model& model, double t, double& fastest) {
  cuda::ObstacleMotionTable table;
  fastest = 0;
  auto add = [&](const ObstacleMotion& m) {
    const Vec3 offset = m.DisplacementAt(t).cast<Real>();
    const Vec3d u = m.VelocityAt(t);
    const Vec3 velocity = u.cast<Real>();
    for (int a = 0; a < 3; ++a) {
      table.offset.push_back(offset[a]);
      table.velocity.push_back(velocity[a]);
    }
    fastest = std::max(fastest, u.norm());
  };
  for (const BoxObstacle& b : model.boxes) add(b.motion);
  for (const SphereObstacle& s : model.spheres) add(s.motion);
  return table;
}

cuda::BoundaryCloud Cloud(const BoundaryParticles& boundary) {
  cuda::BoundaryCloud cloud;
  const size_t nb = boundary.size();
  cloud.x.assign(boundary.grid().xs().begin(), boundary.grid().xs().begin() + nb);
  cloud.y.assign(boundary.grid().ys().begin(), boundary.grid().ys().begin() + nb);
  cloud.z.assign(boundary.grid().zs().begin(), boundary.grid().zs().begin() + nb);
  cloud.volume.assign(boundary.volume().begin(), boundary.volume().end());
  cloud.no_slip.assign(boundary.no_slip().begin(), boundary.no_slip().end());
  for (const Vec3& x : boundary.rest_position()) {
    cloud.rest_x.push_back(x.x()), cloud.rest_y.push_back(x.y()), cloud.rest_z.push_back(x.z());
  }
  cloud.rest_volume.assign(boundary.rest_volume().begin(), boundary.rest_volume().end());
  cloud.rest_no_slip.assign(boundary.rest_no_slip().begin(), boundary.rest_no_slip().end());
  cloud.obstacle.assign(boundary.obstacle().begin(), boundary.obstacle().end());
  return cloud;
}

}  // namespace dysa::cuda_backend
