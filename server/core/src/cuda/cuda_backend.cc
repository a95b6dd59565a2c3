// The CUDA backends of the solvers (built with DYSA_CUDA): the host side that turns a Model into
// the kernels' constants, with the CPU passes' float arithmetic, and moves particles.
#include <algorithm>
#include <cmath>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "cuda/dfsph_pipeline.h"
#include "cuda/seed_pipeline.h"
#include "cuda/wcsph_pipeline.h"
#include "dysa/core/kernels.h"
#include "dysa/core/neighbor_grid.h"
#include "gpu_backend.h"
#include "solvers/dfsph/bender_koschier_solver.h"
#include "solvers/physical/boundary_particles.h"
#include "solvers/physical/cfl_time_step.h"
#include "solvers/physical/particle_shifting.h"
#include "solvers/physical/physical_passes.h"
#include "solvers/seed/seed_solver.h"
#include "solvers/wcsph/becker_teschner_solver.h"

namespace dysa {
namespace cuda {
// The CUDA GPUs this process sees; 0 when the runtime lists none (cuda_probe.cu).
int CudaDeviceCount();
}  // namespace cuda

namespace {

static_assert(sizeof(Vec3) == 3 * sizeof(float), "Vec3 arrays are copied as xyz triples");

float* Floats(std::vector<Vec3>& v) { return v.empty() ? nullptr : v.front().data(); }
const float* Floats(const std::vector<Vec3>& v) { return v.empty() ? nullptr : v.front().data(); }

// A step stopped before it integrated: a grid cell held `count` particles, over the limit.
GpuBackend::StepReport Crowded(uint32_t count) {
  GpuBackend::StepReport report;
  report.max_cell_count = count;
  report.stopped = true;
  return report;
}

cuda::GridLayout Layout(const NeighborGrid& grid) {
  cuda::GridLayout layout;
  for (int a = 0; a < 3; ++a) {
    layout.origin[a] = grid.origin()[a];
    layout.inv_cell[a] = grid.inv_cell_sizes()[a];
    layout.dims[a] = grid.dims()[a];
    layout.periodic[a] = grid.periodic()[a];
    layout.period[a] = grid.periods()[a];
  }
  return layout;
}

void AddObstacles(const Model& model, std::vector<cuda::SphereObstacle>& spheres,
                  std::vector<cuda::BoxObstacle>& boxes);

// The seed's obstacles where the step [t, t + dt] leaves them and their mean velocity over it,
// in float as CollideWithObstacles (seed_solver.cc) computes them.
void PlaceSeedObstacles(const Model& model, double t, double dt,
                        std::vector<cuda::SphereObstacle>& spheres,
                        std::vector<cuda::BoxObstacle>& boxes) {
  auto frame = [&](const ObstacleMotion& m, Vec3& offset, float* velocity) {
    const Vec3d end = m.DisplacementAt(t + dt);
    offset = end.cast<Real>();
    const Vec3 u = ((end - m.DisplacementAt(t)) / dt).cast<Real>();
    for (int a = 0; a < 3; ++a) velocity[a] = u[a];
  };
  for (const SphereObstacle& s : model.spheres) {
    cuda::SphereObstacle& out = spheres.emplace_back();
    Vec3 offset;
    frame(s.motion, offset, out.velocity);
    const Vec3 c = s.center.cast<Real>() + offset;
    for (int a = 0; a < 3; ++a) out.center[a] = c[a];
    out.radius = Real(s.radius);
  }
  for (const BoxObstacle& b : model.boxes) {
    cuda::BoxObstacle& out = boxes.emplace_back();
    Vec3 offset;
    frame(b.motion, offset, out.velocity);
    const Vec3 lo = b.box.min.cast<Real>() + offset, hi = b.box.max.cast<Real>() + offset;
    for (int a = 0; a < 3; ++a) out.lo[a] = lo[a], out.hi[a] = hi[a];
  }
}

// A backend over one of the pipelines: the read-outs they share (cuda::ParticleReadout) and the
// memory they hold, forwarded alike.
template <class Pipeline>
class PipelineBackend : public GpuBackend {
 public:
  void DownloadById(float* position, float* velocity, float* density) const override {
    pipeline_.DownloadById(position, velocity, density);
  }
  RankSubsetCopy DownloadBelowRank(uint32_t threshold, bool position, bool velocity,
                                   bool density) const override {
    return pipeline_.DownloadBelowRank(threshold, position, velocity, density);
  }
  RankSubsetCopy DownloadViewSubset(const ViewSubsetRequest& request, uint64_t budget,
                                    bool position, bool velocity, bool density) const override {
    return pipeline_.DownloadViewSubset(request, budget, position, velocity, density);
  }
  RankSubsetCopy DownloadByIds(const uint32_t* ids, size_t count, bool position, bool velocity,
                               bool density) const override {
    return pipeline_.DownloadByIds(ids, count, position, velocity, density);
  }
  void DownloadPositionBounds(float* lo, float* hi) const override {
    pipeline_.DownloadPositionBounds(lo, hi);
  }
  void GatherProbes(const ProbeGatherPlan& plan, ProbeGather& out) const override {
    pipeline_.GatherProbes(plan, out);
  }
  uint64_t DeviceBytes() const override { return pipeline_.DeviceBytes(); }

 protected:
  PipelineBackend(const Device& device, const DeviceInfo& info) : pipeline_(device.index) {
    info_ = info;
  }

  Pipeline pipeline_;
};

class SeedGpuBackend final : public PipelineBackend<cuda::SeedPipeline> {
 public:
  SeedGpuBackend(const Device& device, const DeviceInfo& info) : PipelineBackend(device, info) {}

  std::vector<std::string> Configure(const Model& model) override {
    const Params& prm = model.params;
    cuda::SeedStepConfig config;
    NeighborGrid grid;  // the CPU pass's layout (seed::SortParticlesIntoGrid)
    grid.Configure(model.domain, Real(prm.smoothing_radius), model.periodic);
    config.grid = Layout(grid);
    // Every constant as the CPU passes compute it (seed_solver.cc), in float.
    const SeedKernelFactors<Real> k(Real(prm.smoothing_radius));
    const Real mass = Real(prm.particle_mass);
    cuda::SeedConstants& c = config.constants;
    c.h = k.h;
    c.h2 = k.h2;
    c.mass_spiky2 = mass * k.spiky2;
    c.mass_spiky3 = mass * k.spiky3;
    c.spiky2_grad = k.spiky2_grad;
    c.spiky3_grad = k.spiky3_grad;
    c.rho0 = Real(prm.target_density);
    c.stiffness = Real(prm.pressure_multiplier);
    c.near_stiffness = Real(prm.near_pressure_multiplier);
    c.mass_dt = Real(prm.particle_mass * model.dt);
    c.viscosity_scale = Real(prm.viscosity * model.dt) * k.poly6;
    c.dt = Real(model.dt);
    c.damping = Real(prm.collision_damping);
    c.speed_limit = Real(prm.smoothing_radius / model.dt);
    for (int a = 0; a < 3; ++a) {
      c.domain_lo[a] = Real(model.domain.min[a]);
      c.domain_hi[a] = Real(model.domain.max[a]);
    }
    config.near = prm.near_pressure_multiplier > 0;
    config.viscosity = prm.viscosity > 0;
    config.gravity_dv = Real(prm.gravity * model.dt);
    config.lookahead = seed::kPredictionLookahead;
    AddObstacles(model, config.spheres, config.boxes);
    return pipeline_.Configure(config);
  }

  void Upload(const ParticleArrays& p, std::span<const SolverArray>) override {
    pipeline_.Upload(p.size(), p.id.data(), Floats(p.position), Floats(p.velocity));
  }

  void Download(ParticleArrays& p) const override {
    p.Resize(pipeline_.size());
    pipeline_.Download(p.id.data(), Floats(p.position), Floats(p.velocity), nullptr,
                       p.density.data(), nullptr, p.pressure.data(), nullptr);
  }

  void DownloadCheckpointArrays(ParticleArrays& p, std::vector<SolverArray>&) const override {
    const size_t n = pipeline_.size();
    p.id.resize(n), p.position.resize(n), p.velocity.resize(n);
    pipeline_.Download(p.id.data(), Floats(p.position), Floats(p.velocity), nullptr, nullptr,
                       nullptr, nullptr, nullptr);
  }

  StepReport Step(const Model& model, State& state) override {
    if (model.HasMovingObstacles()) {
      std::vector<cuda::SphereObstacle> spheres;
      std::vector<cuda::BoxObstacle> boxes;
      PlaceSeedObstacles(model, state.time, state.dt, spheres, boxes);
      pipeline_.MoveObstacles(spheres, boxes);
    }
    cuda::StepOutcome outcome = pipeline_.Step();
    return StepReport{std::move(outcome.pass_ms), outcome.finite, outcome.limited,
                      pipeline_.max_cell_count()};
  }

  bool DownloadSortedCells(std::vector<uint32_t>& cells) const override {
    cells.resize(pipeline_.size());
    pipeline_.DownloadSortedCells(cells.data());
    return true;
  }

  // The seed carries no array from step to step.
  bool DownloadSolverArrays(std::vector<SolverArray>& solver_arrays) const override {
    solver_arrays.clear();
    return true;
  }

  void StageThroughPinnedMemory() override { pipeline_.UsePinnedStaging(true); }
};

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
  grid.Configure(model.domain, Real(model.kernel_support), model.periodic);
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

// The wall contact's obstacles over the step [t, t + dt] (physical::ObstacleFramesOverStep): at
// their displacement at t, with their mean velocity over the step, as LimitApproachToSurfaces
// places them; then handed to the pipeline with the fastest |u|.
template <class Pipeline>
void MoveContactSurfaces(const Model& model, double t, double dt, Pipeline& pipeline) {
  const std::vector<physical::ObstacleFrame> frames =
      physical::ObstacleFramesOverStep(model, t, dt);
  std::vector<cuda::SphereObstacle> spheres;
  std::vector<cuda::BoxObstacle> boxes;
  Real fastest = 0;
  for (size_t o = 0; o < frames.size(); ++o) {
    const physical::ObstacleFrame& f = frames[o];
    fastest = std::max(fastest, f.velocity.norm());
    const bool box = o < model.boxes.size();
    float* velocity = box ? boxes.emplace_back().velocity : spheres.emplace_back().velocity;
    for (int a = 0; a < 3; ++a) velocity[a] = f.velocity[a];
    if (box) {
      const BoxObstacle& b = model.boxes[o];
      const Vec3 lo = (b.box.min + f.displacement).cast<Real>();
      const Vec3 hi = (b.box.max + f.displacement).cast<Real>();
      for (int a = 0; a < 3; ++a) boxes.back().lo[a] = lo[a], boxes.back().hi[a] = hi[a];
    } else {
      const SphereObstacle& s = model.spheres[o - model.boxes.size()];
      const Vec3 c = (s.center + f.displacement).cast<Real>();
      for (int a = 0; a < 3; ++a) spheres.back().center[a] = c[a];
      spheres.back().radius = Real(s.radius);
    }
  }
  pipeline.MoveSurfaces(spheres, boxes, fastest);
}

// The boundary particles in their grid's order, and with a moving obstacle their rest arrays.
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

// Weakly compressible SPH (Becker & Teschner 2007) on the GPU: the passes up to the time step
// run there, the CFL step is chosen here from the maxima they return (CflLimits, the CPU's
// code), and the integration runs there with it.
class WcsphGpuBackend final : public PipelineBackend<cuda::WcsphPipeline> {
 public:
  WcsphGpuBackend(const Device& device, const DeviceInfo& info) : PipelineBackend(device, info) {}

  std::vector<std::string> Configure(const Model& model) override {
    cuda::WcsphStepConfig config;
    config.grid = PhysicalGrid(model);
    config.constants = PhysicalConstants(model);
    // delta h c0, as ComputeInteractions
    config.constants.diffusion = Real(model.params.density_diffusion * model.SmoothingLength() *
                                      model.params.speed_of_sound);
    const BoundaryParticles boundary(model, model.params.particle_spacing, model.kernel_support);
    config.viscosity = model.params.kinematic_viscosity > 0;
    config.wall_viscosity = config.viscosity && boundary.HasNoSlip();
    config.symplectic = model.params.time_integration == 1;
    // A h and the free surface's div r, as ComputeParticleShifting
    config.shifting = Real(model.params.particle_shifting * model.SmoothingLength());
    config.free_surface_divergence = Real(physical::kFreeSurfaceDivergence);
    AddObstacles(model, config.spheres, config.boxes);
    return pipeline_.Configure(config, Cloud(boundary));
  }

  void Upload(const ParticleArrays& p, std::span<const SolverArray> solver_arrays) override {
    const auto* carried = FindSolverArray(solver_arrays, wcsph::kCarriedDensity, p.size());
    pipeline_.Upload(p.size(), p.id.data(), Floats(p.position), Floats(p.velocity),
                     carried ? carried->data() : nullptr);
  }

  void Download(ParticleArrays& p) const override {
    p.Resize(pipeline_.size());
    pipeline_.Download(p.id.data(), Floats(p.position), Floats(p.velocity), p.density.data(),
                       p.pressure.data());
  }

  void DownloadCheckpointArrays(ParticleArrays& p,
                                std::vector<SolverArray>& solver_arrays) const override {
    const size_t n = pipeline_.size();
    p.id.resize(n), p.position.resize(n), p.velocity.resize(n);
    pipeline_.Download(p.id.data(), Floats(p.position), Floats(p.velocity), nullptr, nullptr);
    std::vector<Real> carried(n);
    solver_arrays.clear();
    if (pipeline_.DownloadCarriedDensity(carried.data())) {
      solver_arrays.push_back({std::string(wcsph::kCarriedDensity), std::move(carried)});
    }
  }

  // The gravity, rho^H_ij's factor (as ComputeInteractions) and the boundary's motion at
  // time t for the force passes; obstacle_speed: MoveBoundary's max_obstacle_speed.
  struct ForceInputs {
    Real gravity = 0;
    Real hydrostatic = 0;
    cuda::ObstacleMotionTable motion;
    double obstacle_speed = 0;
  };
  static ForceInputs ForcesAt(const Model& model, double t) {
    ForceInputs in;
    const double g = physical::GravityAt(model.params, t);
    const double c0 = model.params.speed_of_sound;
    in.gravity = Real(g);
    in.hydrostatic = Real(-model.params.rest_density * g / (c0 * c0));
    if (model.HasMovingObstacles()) in.motion = BoundaryMotion(model, t, in.obstacle_speed);
    return in;
  }

  bool DownloadSortedCells(std::vector<uint32_t>& cells) const override {
    cells.resize(pipeline_.size());
    pipeline_.DownloadSortedCells(cells.data());
    return true;
  }

  bool DownloadSolverArrays(std::vector<SolverArray>& solver_arrays) const override {
    std::vector<Real> carried(pipeline_.size());
    solver_arrays.clear();
    if (pipeline_.DownloadCarriedDensity(carried.data())) {
      solver_arrays.push_back({std::string(wcsph::kCarriedDensity), std::move(carried)});
    }
    return true;
  }

  bool DownloadFirstSortCells(std::vector<uint32_t>& ids,
                              std::vector<uint32_t>& cells) const override {
    if (!first_sort_kept_) return false;
    ids = first_ids_;
    cells = first_cells_;
    return true;
  }

  void StageThroughPinnedMemory() override { pipeline_.UsePinnedStaging(true); }

  StepReport Step(const Model& model, State& state) override {
    const bool moving = model.HasMovingObstacles();
    const ForceInputs start = ForcesAt(model, state.time);
    const double obstacle_speed = start.obstacle_speed;
    first_sort_kept_ = false;
    // On one of several processes the ghosts stay out of the maxima (ProcessShare).
    pipeline_.SetOwnedLayers(state.share.layer_axis, state.share.owned_layers);
    const cuda::StepMaxima local = pipeline_.Forces(start.gravity, start.hydrostatic, start.motion);
    // The maxima and the fullest cell over the processes (ChooseStep's max_over_processes; the
    // crowded stop in the same collective, so that every process stops or none): floats and
    // counts convert to double exactly, so they are those of one process.
    double maxima[4] = {double(local.speed2), double(local.acceleration2), double(local.density),
                        double(pipeline_.max_cell_count())};
    state.share.MaxOverProcesses(maxima);
    if (maxima[3] > NeighborGrid::kMaxParticlesPerCell) return Crowded(uint32_t(maxima[3]));
    // ChooseTimeStepPass (cfl_time_step.cc) from the GPU's maxima.
    const double speed = std::max(std::sqrt(maxima[0]), obstacle_speed);
    const TimeStepLimits limits =
        CflLimits(model, speed, std::sqrt(maxima[1]), /*acoustic=*/true, maxima[2]);
    state.dt = ChooseTimeStep(limits, state.max_dt);
    if (std::string warning = SupersonicWarning(model.params, speed); !warning.empty()) {
      state.warning = std::move(warning);
    }
    if (model.params.time_integration == 0) {
      if (moving) MoveContactSurfaces(model, state.time, state.dt, pipeline_);
      cuda::StepOutcome outcome = pipeline_.Integrate(Real(state.dt));
      return StepReport{std::move(outcome.pass_ms), outcome.finite, 0};
    }
    // The predictor-corrector (PredictHalfStep, the force passes at t + dt/2, CorrectStep). On
    // one of several processes the first sort's cells, which the second sort replaces, are kept
    // for the driver's check of the half step's move (DownloadFirstSortCells).
    first_sort_kept_ = !state.share.owned_layers.empty();
    if (first_sort_kept_) {
      first_ids_.resize(pipeline_.size());
      first_cells_.resize(pipeline_.size());
      pipeline_.Download(first_ids_.data(), nullptr, nullptr, nullptr, nullptr);
      pipeline_.DownloadSortedCells(first_cells_.data());
    }
    if (moving) MoveContactSurfaces(model, state.time, state.dt * 0.5, pipeline_);
    pipeline_.Predict(Real(state.dt * 0.5));
    const ForceInputs half = ForcesAt(model, state.time + state.dt * 0.5);
    pipeline_.CorrectorForces(half.gravity, half.hydrostatic, half.motion);
    if (moving) MoveContactSurfaces(model, state.time, state.dt, pipeline_);
    cuda::StepOutcome outcome = pipeline_.Correct(Real(state.dt));
    return StepReport{std::move(outcome.pass_ms), outcome.finite, 0};
  }

 private:
  bool first_sort_kept_ = false;
  std::vector<uint32_t> first_ids_, first_cells_;
};

// Divergence-free SPH (Bender & Koschier 2015/2017) on the GPU: the passes and the solves'
// iterations run there; the two time steps are chosen here (CflLimits, the CPU's code) from the
// maxima the GPU returns.
class DfsphGpuBackend final : public PipelineBackend<cuda::DfsphPipeline> {
 public:
  DfsphGpuBackend(const Device& device, const DeviceInfo& info) : PipelineBackend(device, info) {}

  std::vector<std::string> Configure(const Model& model) override {
    cuda::DfsphStepConfig config;
    config.grid = PhysicalGrid(model);
    config.constants = PhysicalConstants(model);
    const BoundaryParticles boundary(model, model.params.particle_spacing, model.kernel_support);
    config.viscosity = model.params.kinematic_viscosity > 0;
    config.wall_viscosity = config.viscosity && boundary.HasNoSlip();
    config.gradient_moment = Real(model.gradient_moment);
    for (int a = 0; a < 3; ++a) {
      if (model.periodic[a]) config.period[a] = Real(model.domain.max[a] - model.domain.min[a]);
    }
    AddObstacles(model, config.spheres, config.boxes);
    return pipeline_.Configure(config, Cloud(boundary));
  }

  void Upload(const ParticleArrays& p, std::span<const SolverArray> solver_arrays) override {
    // An array the checkpoint does not hold starts cold, as on the CPU
    // (BenderKoschierSolver::RestoreArrays).
    const size_t n = p.size();
    const std::vector<Real> zeros(n, Real(0));
    const auto* density = FindSolverArray(solver_arrays, dfsph::kDensityStiffness, n);
    const auto* divergence = FindSolverArray(solver_arrays, dfsph::kDivergenceStiffness, n);
    pipeline_.Upload(n, p.id.data(), Floats(p.position), Floats(p.velocity),
                     (density ? *density : zeros).data(),
                     (divergence ? *divergence : zeros).data());
  }

  void Download(ParticleArrays& p) const override {
    p.Resize(pipeline_.size());
    pipeline_.Download(p.id.data(), Floats(p.position), Floats(p.velocity), p.density.data(),
                       p.pressure.data(), nullptr, nullptr);
  }

  void DownloadCheckpointArrays(ParticleArrays& p,
                                std::vector<SolverArray>& solver_arrays) const override {
    const size_t n = pipeline_.size();
    p.id.resize(n), p.position.resize(n), p.velocity.resize(n);
    solver_arrays = {{std::string(dfsph::kDensityStiffness), std::vector<Real>(n)},
                     {std::string(dfsph::kDivergenceStiffness), std::vector<Real>(n)}};
    pipeline_.Download(p.id.data(), Floats(p.position), Floats(p.velocity), nullptr, nullptr,
                       solver_arrays[0].values.data(), solver_arrays[1].values.data());
  }

  StepReport Step(const Model& model, State& state) override {
    const Params& prm = model.params;
    const Real gravity = Real(physical::GravityAt(prm, state.time));
    SolverStats& stats = stats_;
    const uint64_t step = state.step + 1;
    // DivergenceSolve's step: the one the time_step pass will choose from these velocities.
    const bool moving = model.HasMovingObstacles();
    double obstacle_speed = 0;  // MoveBoundary's max_obstacle_speed
    const cuda::ObstacleMotionTable motion =
        moving ? BoundaryMotion(model, state.time, obstacle_speed) : cuda::ObstacleMotionTable{};
    const float speed2 = pipeline_.Prepare(gravity, NeighborGrid::kMaxParticlesPerCell, motion);
    if (pipeline_.max_cell_count() > NeighborGrid::kMaxParticlesPerCell) {
      return Crowded(pipeline_.max_cell_count());
    }
    const double divergence_dt =
        std::min(CflLimits(model, std::max(std::sqrt(double(speed2)), obstacle_speed),
                           std::abs(prm.gravity), false)
                     .Min(),
                 prm.max_time_step);
    const cuda::SolveResult divergence = pipeline_.DivergenceSolve(
        divergence_dt, {prm.divergence_tolerance, prm.max_iterations, Real(prm.warm_start)});
    Record(divergence, "divergence", prm.divergence_tolerance, step, stats.divergence_iterations,
           stats.divergence_error, state);
    // ChooseIncompressibleTimeStepPass from the GPU's maxima.
    const cuda::StepMaxima maxima = pipeline_.Forces(gravity);
    const double speed = std::max(std::sqrt(double(maxima.speed2)), obstacle_speed);
    const TimeStepLimits limits = CflLimits(model, speed, std::sqrt(double(maxima.acceleration2)),
                                            /*acoustic=*/false, maxima.density);
    state.dt = ChooseTimeStep(limits, state.max_dt);
    if (prm.cfl_factor > kIncompressibleMaxCfl) {
      state.warning = "cfl_factor " + std::to_string(prm.cfl_factor) +
                      " is beyond the incompressible solver's stability limit; steps use " +
                      std::to_string(kIncompressibleMaxCfl);
    }
    const Real dt = Real(state.dt);
    const cuda::SolveResult density = pipeline_.DensitySolve(
        dt, {prm.density_tolerance, prm.max_iterations, Real(prm.warm_start)});
    Record(density, "density", prm.density_tolerance, step, stats.density_iterations,
           stats.density_error, state);
    if (moving) MoveContactSurfaces(model, state.time, state.dt, pipeline_);
    cuda::StepOutcome outcome = pipeline_.Integrate(dt, Real(prm.particle_spacing / state.dt));
    if (outcome.limited > 0) state.warning = dfsph::SpeedLimitWarning(outcome.limited, step);
    return StepReport{std::move(outcome.pass_ms), outcome.finite, 0};
  }

  SolverStats stats() const override { return stats_; }

 private:
  // A solve's statistics into stats_, and its warning when it stopped at the cap.
  void Record(const cuda::SolveResult& result, const char* solve, double tolerance, uint64_t step,
              int& iterations, double& error, State& state) {
    iterations = result.iterations;
    error = result.error;
    if (result.capped) {
      ++stats_.capped_solves;
      state.warning = dfsph::CapWarning(solve, result.iterations, result.error, tolerance, step);
    }
  }

  SolverStats stats_;
};

}  // namespace

bool CudaBackendBuilt() { return true; }

int CudaDeviceCount() { return cuda::CudaDeviceCount(); }

std::string DeviceUnavailableReason(const Device& device) {
  if (!device.is_cuda()) return "";
  return cuda::ProbeCudaDevice(device.index, nullptr);
}

DeviceInfo QueryDevice(const Device& device) {
  DeviceInfo info;
  if (!device.is_cuda()) {
    info.name = "cpu";
    return info;
  }
  cuda::GpuProperties props;
  const std::string reason = cuda::ProbeCudaDevice(device.index, &props);
  if (!reason.empty()) throw ConfigError("device", reason);
  info.name = props.name;
  info.memory_bytes = props.memory_bytes;
  info.compute_capability = props.compute_capability;
  return info;
}

std::vector<std::string> GpuSolvers() { return {"seed", "wcsph", "dfsph"}; }

std::unique_ptr<GpuBackend> CreateGpuBackend(const Device& device, std::string_view solver) {
  const DeviceInfo info = QueryDevice(device);  // throws, naming what is missing
  if (solver == "seed") return std::make_unique<SeedGpuBackend>(device, info);
  if (solver == "wcsph") return std::make_unique<WcsphGpuBackend>(device, info);
  if (solver == "dfsph") return std::make_unique<DfsphGpuBackend>(device, info);
  throw ConfigError("device", "the solver \"" + std::string(solver) +
                                  "\" has no CUDA backend (GPU solvers: seed, wcsph, dfsph); "
                                  "run it with --device cpu");
}

}  // namespace dysa
