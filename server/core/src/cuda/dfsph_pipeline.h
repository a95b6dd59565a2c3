// The dfsph solver's step on a CUDA GPU (solvers/dfsph/bender_koschier_solver.h): the plain
// interface between the host code, which chooses the time steps with the CPU's CflLimits, and
// the kernels.
//
// The passes are the CPU's, each kernel with the CPU's operations in the CPU's order, and the
// pair lists of the density pass are laid out as the CPU's (per particle in the grid's order; the
// walls' transpose in fluid order, by a stable sort), but hold only the other particle: the
// solves recompute each pair's grad W from the positions with the density pass's operations
// (PairGradW, dfsph_kernels.cuh), 4 bytes a pair read instead of 16. One thing differs: the
// solves' stopping test sums the particles' errors in a fixed tree order on the GPU, not
// serially, so the iteration counts may differ from the CPU's by one now and then; the GPU's own
// runs stay bit-identical (no atomics in any sum).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "cuda/gpu_types.h"
#include "cuda/particle_readout.h"
#include "cuda/wcsph_pipeline.h"

namespace dysa::cuda {

struct DfsphStepConfig {
  GridLayout grid;
  SphConstants constants;
  bool viscosity = false;
  bool wall_viscosity = false;
  float gradient_moment = 1;  // mu (kernels.h), for the reported pressure
  // m, the domain's length along each periodic axis (as Model::MinimumImage rounds it), else 0.
  float period[3] = {0, 0, 0};
  std::vector<SphereObstacle> spheres;
  std::vector<BoxObstacle> boxes;
};

// One pressure solve's settings and, afterwards, its outcome.
struct SolveSettings {
  double tolerance = 0;  // of the mean error, as a fraction of rho0
  int max_iterations = 0;
  float warm_start = 0;
};
struct SolveResult {
  int iterations = 0;
  double error = 0;  // the mean error at the end, as a fraction of rho0
  bool capped = false;
};

// DownloadById, DownloadBelowRank, DownloadViewSubset, DownloadByIds, DownloadPositionBounds,
// size, max_cell_count and GatherProbes are ParticleReadout's.
class DfsphPipeline : public ParticleReadout {
 public:
  explicit DfsphPipeline(int device);
  ~DfsphPipeline();
  DfsphPipeline(const DfsphPipeline&) = delete;
  DfsphPipeline& operator=(const DfsphPipeline&) = delete;

  std::vector<std::string> Configure(const DfsphStepConfig& config, const BoundaryCloud& boundary);
  // ids, n xyz positions and velocities, and the two warm-start arrays (kappa dt^2, kappa dt).
  void Upload(size_t n, const uint32_t* id, const float* position, const float* velocity,
              const float* density_stiffness, const float* divergence_stiffness);
  void Download(uint32_t* id, float* position, float* velocity, float* density, float* pressure,
                float* density_stiffness, float* divergence_stiffness) const;

  // move_boundary with `motion` when the boundary has moving obstacles, neighbour_grid,
  // density (the pair lists), boundary_pressure (the walls' Shepard weights and hydrostatic
  // acceleration, with gravity `gravity`); returns the largest |v|^2, from which the caller
  // sizes the divergence solve's step. Stops after counting the pairs, before listing them,
  // when a grid cell holds more than `max_per_cell` particles (max_cell_count()): the lists
  // would hold n^2 pairs.
  float Prepare(float gravity, uint32_t max_per_cell, const ObstacleMotionTable& motion);
  // divergence_solve with the step dt (s).
  SolveResult DivergenceSolve(double dt, const SolveSettings& settings);
  // external_forces, viscosity, wall_viscosity, and the time_step pass's maxima.
  StepMaxima Forces(float gravity);
  // predict_velocity and density_solve with the step dt; the pressures reported.
  SolveResult DensitySolve(float dt, const SolveSettings& settings);
  // integrate: x += v dt with the speed limit (m/s) and the wall contact. Returns every pass's
  // time and the count of particles the limit slowed.
  StepOutcome Integrate(float dt, float speed_limit);
  // As WcsphPipeline::MoveSurfaces: the contact's obstacles over the coming integration.
  void MoveSurfaces(const std::vector<SphereObstacle>& spheres,
                    const std::vector<BoxObstacle>& boxes, float obstacle_speed);
  uint64_t DeviceBytes() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dysa::cuda
