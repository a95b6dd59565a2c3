#include "dysa/distributed/ranks_backend.h"

#include <array>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "dysa/core/neighbor_grid.h"
#include "dysa/distributed/rank_device.h"

namespace dysa::distributed {
namespace {

// Each particle's values at its id's entries (null: not copied).
void ScatterById(const ParticleArrays& p, float* position, float* velocity, float* density) {
#pragma omp parallel for schedule(static)
  for (size_t i = 0; i < p.size(); ++i) {
    const size_t k = p.id[i];
    for (int a = 0; a < 3; ++a) {
      if (position) position[3 * k + a] = p.position[i][a];
      if (velocity) velocity[3 * k + a] = p.velocity[i][a];
    }
    if (density) density[k] = p.density[i];
  }
}

uint32_t Fields(const float* position, const float* velocity, const float* density) {
  return (position ? uint32_t(kReadPosition) : 0u) | (velocity ? uint32_t(kReadVelocity) : 0u) |
         (density ? uint32_t(kReadDensity) : 0u);
}

class RanksBackend final : public StepBackend {
 public:
  RanksBackend(std::shared_ptr<RankRunner> runner, const Scene& scene)
      : runner_(std::move(runner)), scene_(scene) {
    CheckRunsOnRanks(scene_, scene_.params, runner_->comm().size(), runner_->device());
    runner_->Send(SceneCommand(scene_));
  }

  // "cpu, 3 ranks", "cuda:0, 3 ranks" (all on one GPU), "cuda:0 cuda:1, 2 ranks".
  std::string Describe(const Device&) const override {
    const int n = runner_->comm().size();
    return DescribeRankDevices(runner_->devices()) + ", " + std::to_string(n) +
           (n == 1 ? " rank" : " ranks");
  }

  void CheckParams(const Params& params) const override {
    CheckRunsOnRanks(scene_, params, runner_->comm().size(), runner_->device());
  }

  std::vector<std::string> Configure(const Model& model) override {
    runner_->Send(ConfigureCommand(model.params));
    std::vector<std::string> names;
    for (const PassProfile& p : sim().profile()) names.push_back(p.name);
    return names;
  }

  void Upload(const ParticleArrays& particles, std::span<const SolverArray> arrays) override {
    runner_->Send(UploadCommand(particles, arrays));
  }

  void Download(ParticleArrays& particles) const override {
    particles = std::move(runner_->Send(GatherCommand()).particles);
  }

  void DownloadCheckpointArrays(ParticleArrays& p,
                                std::vector<SolverArray>& arrays) const override {
    Checkpoint c = std::move(runner_->Send(CheckpointCommand()).checkpoint);
    p.id = std::move(c.id);
    p.position = std::move(c.position);
    p.velocity = std::move(c.velocity);
    arrays = std::move(c.solver_arrays);
  }

  void DownloadById(float* position, float* velocity, float* density) const override {
    ScatterById(runner_->Send(GatherCommand()).particles, position, velocity, density);
  }

  // A budgeted stream's frame: each rank sends only its particles of the subset.
  std::optional<size_t> DownloadByIdBelowRank(uint32_t threshold, float* position, float* velocity,
                                              float* density) const override {
    const ParticleArrays p = std::move(runner_->Send(GatherCommand(threshold)).particles);
    ScatterById(p, position, velocity, density);
    return p.size();
  }

  // A view stream's reads: each rank sends only what the view asks of its own particles.
  std::optional<size_t> GatherByIds(std::span<const uint32_t> ids, float* position, float* velocity,
                                    float* density) const override {
    const RankResult r = runner_->Send(ReadIdsCommand(ids, Fields(position, velocity, density)));
    ScatterById(r.particles, position, velocity, density);
    return ids.size();
  }

  bool ReducePositionBounds(std::array<float, 3>& lo, std::array<float, 3>& hi) const override {
    const Simulation::PositionBounds b = runner_->Send(PositionBoundsCommand()).bounds;
    lo = b.lo;
    hi = b.hi;
    return true;
  }

  std::optional<size_t> SelectViewSubset(const ViewSubsetRequest& request, uint64_t budget,
                                         std::vector<uint32_t>& ids, float* position,
                                         float* velocity, float* density) const override {
    RankResult r = runner_->Send(
        ViewSubsetCommand(request, budget, Fields(position, velocity, density)), &request.weigh);
    ScatterById(r.particles, position, velocity, density);
    ids = std::move(r.ids);
    return ids.size();
  }

  bool gathers_probes() const override { return false; }
  void GatherProbes(const ProbeGatherPlan&, ProbeGather&) const override {
    throw std::logic_error("the ranks' backend gathers no probes (gathers_probes)");
  }

  StepReport Step(const Model& model, State& state) override {
    const double cap = model.physical ? state.max_dt : model.dt;
    const DistributedSimulation::StepOutcome outcome =
        runner_->Send(StepCommand(state.time, state.step, cap)).outcome;
    StepReport report;
    for (const PassProfile& p : sim().profile()) report.pass_ms.push_back(p.last_ms);
    if (!outcome.completed) {
      report.alarm = sim().alarm();
      report.stopped = true;
      return report;
    }
    state.dt = outcome.dt;
    report.finite = outcome.finite;
    // A physical solver's warnings (the flow past the speed of sound; dfsph's iteration cap and
    // speed limiter) come from the maxima and integer sums over the ranks; the seed's velocity
    // limiter counts each rank's ghosts too, so its count is not one process's: not reported.
    if (model.physical && !sim().warning().empty()) state.warning = sim().warning();
    return report;
  }

  uint64_t DeviceBytes() const override { return 0; }

 private:
  const DistributedSimulation& sim() const { return *runner_->simulation(); }

  std::shared_ptr<RankRunner> runner_;
  Scene scene_;
};

}  // namespace

void CheckRunsOnRanks(const Scene& scene, const Params& params, int processes,
                      const Device& device) {
  // What `dysa run` under mpirun refuses too: a solver not made to run across processes (on GPU
  // ranks, one the device's step does not run: none of those the ranks run today).
  DistributedSimulation::CheckSupported(scene, params, device);
  if (scene.source_json.empty()) {
    throw ConfigError("scene", "'" + scene.name +
                                   "' was built in code, not read from JSON text: the ranks "
                                   "build their scene from its text");
  }
  const Model model = MakeModel(scene, params);
  NeighborGrid layout;
  layout.Configure(model.domain, Real(model.kernel_support), model.periodic,
                   model.grid_cells_per_support);
  const int layers = layout.dims().maxCoeff();
  if (layers < processes) {
    throw ConfigError("processes", "the neighbour grid has " + std::to_string(layers) +
                                       " cell layers along its longest axis, fewer than the " +
                                       std::to_string(processes) +
                                       " ranks that must each own one: run on at most " +
                                       std::to_string(layers) + " ranks");
  }
}

Simulation::BackendFactory RanksBackendFactory(std::shared_ptr<RankRunner> runner) {
  return [runner](const Scene& scene) -> std::unique_ptr<StepBackend> {
    return std::make_unique<RanksBackend>(runner, scene);
  };
}

}  // namespace dysa::distributed
