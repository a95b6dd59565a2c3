// The dfsph solver's step on a CUDA GPU (solvers/dfsph/bender_koschier_solver.h): the plain
// interface between the host code, which chooses the time steps with the CPU's CflLimits, and
// the kernels.
//
// The passes are the CPU's, each kernel with the CPU's operations in the CPU's order, and the
// pair lists of the density pass are laid out as the CPU's (per particle in the grid's order; the
// walls' transpose in fluid order, by a stable sort), but hold only the other particle: the
// solves recompute each pair's grad W from the positions with the density pass's operations
// (PairGradW, dfsph_kernels.cuh), 4 bytes a pair read instead of 16. The solves' stopping test
// sums the particles' errors as fixed-point integers (fixed_point_sum.cuh), the CPU's sum bit for
// bit whatever the order, so a solve stops at the CPU's iteration.
//
// On one of several processes (SetProcesses: the ranks' device step, server/distributed) the
// pipeline steps this process's owned particles and ghosts, and the reductions and refreshes the
// CPU path makes through ProcessShare go through DfsphProcesses (dfsph_ranks.cuh).
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
  bool signed_corrections = false;  // Params::signed_corrections
};
struct SolveResult {
  int iterations = 0;
  double error = 0;  // the mean error at the end, as a fraction of rho0
  bool capped = false;
};

// One of several processes' link to the others, for the solves (SetProcesses). Every call is
// collective: every process makes the same calls in the same order, whatever it holds (none
// included).
class DfsphProcesses {
 public:
  virtual ~DfsphProcesses() = default;
  // values[k] becomes its sum over the processes (integers: exact in any order).
  virtual void Sum(int64_t* values, size_t count) = 0;
  // values[k] becomes its maximum over the processes (exact in any order).
  virtual void Max(double* values, size_t count) = 0;
  // The ghosts' velocities (xyz triples): `sent` holds those of the plan's `sent` particles, in
  // its order; `received` gets those of its `received` ghosts, from their owners.
  virtual void ExchangeVelocities(const float* sent, size_t sent_count, float* received,
                                  size_t received_count) = 0;
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

  // Upload and Download (and DownloadSortedOrder) copy through page-locked host buffers kept
  // between calls (the ranks' device step copies every step).
  void UsePinnedStaging(bool on);
  // After Prepare: each particle's id and the cell (NeighborGrid::CellIndex) it was sorted into,
  // in storage order (null: not copied).
  void DownloadSortedOrder(uint32_t* id, uint32_t* cells) const;

  // move_boundary with `motion` when the boundary has moving obstacles, neighbour_grid,
  // density (the pair lists), boundary_pressure (the walls' Shepard weights and hydrostatic
  // acceleration, with gravity `gravity`). Stops after counting the pairs, before listing them,
  // when a grid cell holds more than `max_per_cell` particles (max_cell_count()): the lists
  // would hold n^2 pairs.
  void Prepare(float gravity, uint32_t max_per_cell, const ObstacleMotionTable& motion);
  // On one of several processes, after Prepare, for the rest of the step: `processes` links the
  // solves to the others; per particle (storage order) `ghost` is 0 for an owned particle; the
  // ghosts' refresh reads back the velocities of the particles `sent` and writes those of the
  // ghosts `received` (DeviceGhostExchange::Plan). The reductions that steer the step (the
  // solves' mean errors, MaxSpeed2, the time step's maxima, the speed limiter's count) then
  // leave the ghosts out, the mean errors are combined over the processes, the warm start
  // applies on every process or on none, and every update of the velocities is followed by the
  // ghosts' refresh. Null `processes`: one process (the default; the arrays are not read).
  void SetProcesses(DfsphProcesses* processes, const uint8_t* ghost, const uint32_t* sent,
                    size_t sent_count, const uint32_t* received, size_t received_count);
  // The largest |v|^2 of the owned particles (0 without), from which the caller sizes the
  // divergence solve's step.
  float MaxSpeed2();
  // divergence_solve with the step dt (s).
  SolveResult DivergenceSolve(double dt, const SolveSettings& settings);
  // external_forces, viscosity, wall_viscosity, and the time_step pass's maxima (of the owned
  // particles).
  StepMaxima Forces(float gravity);
  // predict_velocity and density_solve with the step dt; the pressures reported.
  SolveResult DensitySolve(float dt, const SolveSettings& settings);
  // integrate: x += v dt with the speed limit (m/s) and the wall contact. Returns every pass's
  // time and the count of owned particles the limit slowed.
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
