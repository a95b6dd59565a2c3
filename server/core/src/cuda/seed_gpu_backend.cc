// The seed model (the thesis's solver, seed_solver.cc) on the GPU: its step runs there whole.
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "cuda/pipeline_backend.h"
#include "cuda/seed_pipeline.h"
#include "solvers/seed/seed_solver.h"

namespace dysa::cuda_backend {
namespace {

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

}  // namespace

std::unique_ptr<GpuBackend> MakeSeedGpuBackend(const Device& device, const DeviceInfo& info) {
  return std::make_unique<SeedGpuBackend>(device, info);
}

}  // namespace dysa::cuda_backend
