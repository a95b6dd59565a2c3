// Weakly compressible SPH on the GPU (WcsphGpuBackend, below).
#include <algorithm>
#include <cmath>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "cuda/pipeline_backend.h"
#include "cuda/wcsph_pipeline.h"
#include "solvers/physical/boundary_particles.h"
#include "solvers/physical/cfl_time_step.h"
#include "solvers/physical/particle_shifting.h"
#include "solvers/wcsph/becker_teschner_solver.h"

namespace dysa::cuda_backend {
namespace {

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
    // 2 alpha c0 h m and alpha c0 h, as ComputeInteractions
    const double artificial = wcsph::ArtificialViscosityStrength(model);
    config.constants.artificial_scale = Real(2 * artificial * model.particle_mass);
    config.constants.wall_artificial_scale = Real(artificial);
    config.artificial_viscosity = artificial > 0;
    config.wall_artificial_viscosity = config.artificial_viscosity && boundary.HasNoSlip();
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

}  // namespace

std::unique_ptr<GpuBackend> MakeWcsphGpuBackend(const Device& device, const DeviceInfo& info) {
  return std::make_unique<WcsphGpuBackend>(device, info);
}

}  // namespace dysa::cuda_backend
