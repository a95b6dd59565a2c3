// Divergence-free SPH on the GPU (DfsphGpuBackend, below).
#include <algorithm>
#include <cmath>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "cuda/dfsph_pipeline.h"
#include "cuda/pipeline_backend.h"
#include "solvers/dfsph/bender_koschier_solver.h"
#include "solvers/physical/boundary_particles.h"
#include "solvers/physical/cfl_time_step.h"

namespace dysa::cuda_backend {
namespace {

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

std::unique_ptr<GpuBackend> MakeDfsphGpuBackend(const Device& device, const DeviceInfo& info) {
  return std::make_unique<DfsphGpuBackend>(device, info);
}

}  // namespace dysa::cuda_backend
