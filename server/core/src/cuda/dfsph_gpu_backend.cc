// Divergence-free SPH on the GPU (DfsphGpuBackend, below).
#include <algorithm>
#include <cmath>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "cuda/dfsph_pipeline.h"
#include "cuda/pipeline_backend.h"
#include "dysa/core/device_ghost_exchange.h"
#include "solvers/dfsph/bender_koschier_solver.h"
#include "solvers/physical/boundary_particles.h"
#include "solvers/physical/cfl_time_step.h"

namespace dysa::cuda_backend {
namespace {

// The pipeline's link to the other processes (cuda::DfsphProcesses) over what the driver of the
// processes hands every step (State::share): its sums and maxima (ProcessShare, as the CPU's
// passes use them) and its ghost exchange (ProcessShare::device_ghosts).
class ShareLink final : public cuda::DfsphProcesses {
 public:
  explicit ShareLink(const ProcessShare& share) : share_(share) {}
  void Sum(int64_t* values, size_t count) override { share_.SumOverProcesses({values, count}); }
  void Max(double* values, size_t count) override { share_.MaxOverProcesses({values, count}); }
  // xyz triples are Vec3s (pipeline_backend.h's static_assert): no copy on the host.
  void ExchangeVelocities(const float* sent, size_t sent_count, float* received,
                          size_t received_count) override {
    share_.device_ghosts->Exchange({reinterpret_cast<const Vec3*>(sent), sent_count},
                                   {reinterpret_cast<Vec3*>(received), received_count});
  }

 private:
  const ProcessShare& share_;
};

// Divergence-free SPH (Bender & Koschier 2015/2017) on the GPU: the passes and the solves'
// iterations run there; the two time steps are chosen here (CflLimits, the CPU's code) from the
// maxima the GPU returns. On one of several processes (State::share: the ranks' device step,
// server/distributed) it also plans the ghosts' refresh after the sort (DeviceGhostExchange),
// and combines over the processes the crowded cell, the maxima and the speed limiter's count as
// the CPU's passes do; the solves combine their errors and refresh the ghosts through ShareLink.
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

  bool DownloadSolverArrays(std::vector<SolverArray>& solver_arrays) const override {
    const size_t n = pipeline_.size();
    solver_arrays = {{std::string(dfsph::kDensityStiffness), std::vector<Real>(n)},
                     {std::string(dfsph::kDivergenceStiffness), std::vector<Real>(n)}};
    pipeline_.Download(nullptr, nullptr, nullptr, nullptr, nullptr, solver_arrays[0].values.data(),
                       solver_arrays[1].values.data());
    return true;
  }

  bool DownloadSortedCells(std::vector<uint32_t>& cells) const override {
    cells.resize(pipeline_.size());
    pipeline_.DownloadSortedOrder(nullptr, cells.data());
    return true;
  }

  void StageThroughPinnedMemory() override { pipeline_.UsePinnedStaging(true); }

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
    pipeline_.Prepare(gravity, NeighborGrid::kMaxParticlesPerCell, motion);
    // One of several processes: the step stops on every process or on none (AfterSort's test),
    // then the refresh's pattern from the sort.
    const ProcessShare& share = state.share;
    const bool spread = share.device_ghosts != nullptr;
    if (!spread && !share.owned_layers.empty()) {
      throw std::logic_error("dfsph on one of several processes needs the ghosts' exchange");
    }
    double crowd = double(pipeline_.max_cell_count());
    if (spread) share.MaxOverProcesses({&crowd, 1});
    if (crowd > NeighborGrid::kMaxParticlesPerCell) return Crowded(uint32_t(crowd));
    if (spread) PlanGhostRefresh(share);
    // MaxSpeed (bender_koschier_solver.cc): of the owned particles, over the processes.
    double speed2 = double(pipeline_.MaxSpeed2());
    if (spread) share.MaxOverProcesses({&speed2, 1});
    const double divergence_dt = std::min(
        CflLimits(model, std::max(std::sqrt(speed2), obstacle_speed), std::abs(prm.gravity), false)
            .Min(),
        prm.max_time_step);
    const cuda::SolveResult divergence = pipeline_.DivergenceSolve(
        divergence_dt, {prm.divergence_tolerance, prm.max_iterations, Real(prm.warm_start),
                        prm.signed_corrections != 0});
    Record(divergence, "divergence", prm.divergence_tolerance, step, stats.divergence_iterations,
           stats.divergence_error, state);
    // ChooseIncompressibleTimeStepPass from the GPU's maxima (over the processes: floats convert
    // to double exactly, so they are those of one process).
    const cuda::StepMaxima local = pipeline_.Forces(gravity);
    double maxima[3] = {double(local.speed2), double(local.acceleration2), double(local.density)};
    if (spread) share.MaxOverProcesses(maxima);
    const double speed = std::max(std::sqrt(maxima[0]), obstacle_speed);
    const TimeStepLimits limits =
        CflLimits(model, speed, std::sqrt(maxima[1]), /*acoustic=*/false, maxima[2]);
    state.dt = ChooseTimeStep(limits, state.max_dt);
    if (prm.cfl_factor > kIncompressibleMaxCfl) {
      state.warning = "cfl_factor " + std::to_string(prm.cfl_factor) +
                      " is beyond the incompressible solver's stability limit; steps use " +
                      std::to_string(kIncompressibleMaxCfl);
    }
    const Real dt = Real(state.dt);
    const cuda::SolveResult density =
        pipeline_.DensitySolve(dt, {prm.density_tolerance, prm.max_iterations, Real(prm.warm_start),
                                    prm.signed_corrections != 0});
    Record(density, "density", prm.density_tolerance, step, stats.density_iterations,
           stats.density_error, state);
    if (moving) MoveContactSurfaces(model, state.time, state.dt, pipeline_);
    cuda::StepOutcome outcome = pipeline_.Integrate(dt, Real(prm.particle_spacing / state.dt));
    // The owned particles the limit slowed, over the processes (IntegratePositions).
    int64_t limited = int64_t(outcome.limited);
    if (spread) share.SumOverProcesses({&limited, 1});
    if (limited > 0) state.warning = dfsph::SpeedLimitWarning(uint64_t(limited), step);
    return StepReport{std::move(outcome.pass_ms), outcome.finite, 0};
  }

  SolverStats stats() const override { return stats_; }

 private:
  // After the sort, on one of several processes: each particle's id and cell to the driver,
  // which plans the refresh (collective); its ghost flags and pattern to the pipeline, linked
  // to the other processes for the rest of the step.
  void PlanGhostRefresh(const ProcessShare& share) {
    const size_t n = pipeline_.size();
    sorted_ids_.resize(n);
    sorted_cells_.resize(n);
    pipeline_.DownloadSortedOrder(sorted_ids_.data(), sorted_cells_.data());
    const DeviceGhostExchange::Plan plan =
        share.device_ghosts->PlanAfterSort(sorted_ids_, sorted_cells_);
    if (plan.ghost.size() != n) throw std::logic_error("the ghost flags do not fit the particles");
    link_ = std::make_unique<ShareLink>(share);
    pipeline_.SetProcesses(link_.get(), plan.ghost.data(), plan.sent.data(), plan.sent.size(),
                           plan.received.data(), plan.received.size());
  }

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
  std::unique_ptr<ShareLink> link_;  // the latest step's, on one of several processes
  std::vector<uint32_t> sorted_ids_, sorted_cells_;
};

}  // namespace

std::unique_ptr<GpuBackend> MakeDfsphGpuBackend(const Device& device, const DeviceInfo& info) {
  return std::make_unique<DfsphGpuBackend>(device, info);
}

}  // namespace dysa::cuda_backend
