// What the CUDA backends of the solvers share (seed_gpu_backend.cc, wcsph_gpu_backend.cc,
// dfsph_gpu_backend.cc; cuda_backend.cc makes them): the backend over a pipeline, and the host
// side that turns a Model into the kernels' grid, constants and obstacles with the CPU passes'
// float arithmetic.
#pragma once

#include <algorithm>
#include <memory>
#include <vector>

#include "cuda/gpu_types.h"
#include "cuda/wcsph_pipeline.h"
#include "dysa/core/neighbor_grid.h"
#include "gpu_backend.h"
#include "solvers/physical/boundary_particles.h"
#include "solvers/physical/physical_passes.h"

namespace dysa::cuda_backend {

static_assert(sizeof(Vec3) == 3 * sizeof(float), "Vec3 arrays are copied as xyz triples");

inline float* Floats(std::vector<Vec3>& v) { return v.empty() ? nullptr : v.front().data(); }
inline const float* Floats(const std::vector<Vec3>& v) {
  return v.empty() ? nullptr : v.front().data();
}

// A step stopped before it integrated: a grid cell held `count` particles, over the limit.
inline GpuBackend::StepReport Crowded(uint32_t count) {
  GpuBackend::StepReport report;
  report.max_cell_count = count;
  report.stopped = true;
  return report;
}

// The kernels' layout of a CPU grid.
cuda::GridLayout Layout(const NeighborGrid& grid);

// The model's obstacles at rest (their scene positions), in float.
void AddObstacles(const Model& model, std::vector<cuda::SphereObstacle>& spheres,
                  std::vector<cuda::BoxObstacle>& boxes);

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

// The fluid grid of the physical solvers (physical::SortIntoGrid's layout).
cuda::GridLayout PhysicalGrid(const Model& model);
// The physical solvers' constants as their CPU passes compute them (becker_teschner_solver.cc,
// bender_koschier_solver.cc).
cuda::SphConstants PhysicalConstants(const Model& model);
// The move_boundary pass's table (physical::MoveBoundary): each obstacle's displacement and
// velocity at the step's start t; `fastest` the largest |u| (m/s), which the CFL step counts.
cuda::ObstacleMotionTable BoundaryMotion(const Model& model, double t, double& fastest);
// The boundary particles in their grid's order, and with a moving obstacle their rest arrays.
cuda::BoundaryCloud Cloud(const BoundaryParticles& boundary);

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

// The backends, on `device` (described by `info`).
std::unique_ptr<GpuBackend> MakeSeedGpuBackend(const Device& device, const DeviceInfo& info);
std::unique_ptr<GpuBackend> MakeWcsphGpuBackend(const Device& device, const DeviceInfo& info);
std::unique_ptr<GpuBackend> MakeDfsphGpuBackend(const Device& device, const DeviceInfo& info);

}  // namespace dysa::cuda_backend
