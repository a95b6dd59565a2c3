// The seed solver's step on a CUDA GPU (the interface between the host code, compiled by the C++
// compiler with Eigen, and the kernels, compiled by nvcc without it: plain types only).
//
// The particles live in device memory from Upload() to Download(); a step is the CPU solver's
// pass list (solvers/seed/seed_solver.h) run as kernels, one thread per particle, each thread
// writing only its own particle (gather), so the result does not depend on scheduling.
//
// Bit-identical to the CPU: every kernel performs the CPU pass's floating-point operations in
// the CPU's order. The CPU's neighbour loops accumulate in 8 lanes (simd.h), lane l taking the
// candidates begin + l, begin + l + 8, ... of each run, and add the lanes 0..7 at the end; a
// GPU thread keeps the same 8 partial sums in registers, or, where it reads a neighbour list
// built by the density pass, each lane's in turn (seed_neighbour_list.cuh). nvcc compiles these
// kernels with --fmad=false (no fused multiply-add, as the CPU's -ffp-contract=off), IEEE division
// and square root. Lanes the CPU masks off add +0 or subtract a signed zero from a sum that is
// never -0, which changes nothing, so the GPU skips them.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "cuda/gpu_types.h"
#include "cuda/particle_readout.h"

namespace dysa::cuda {

// The constants the seed's kernels read, computed on the host in the CPU passes' float
// arithmetic (a kernel argument: plain values only).
struct SeedConstants {
  float h = 0, h2 = 0;    // m, smoothing radius and its square
  float mass_spiky2 = 0;  // particle_mass * the spiky^2 factor
  float mass_spiky3 = 0;  // particle_mass * the spiky^3 factor
  float spiky2_grad = 0, spiky3_grad = 0;
  float rho0 = 0;             // kg/m^3, target_density
  float stiffness = 0;        // pressure_multiplier
  float near_stiffness = 0;   // near_pressure_multiplier
  float mass_dt = 0;          // particle_mass * dt
  float viscosity_scale = 0;  // viscosity * dt * the poly6 factor
  float dt = 0;               // s
  float damping = 0;          // collision_damping
  float speed_limit = 0;      // m/s, smoothing_radius / dt
  float domain_lo[3] = {0, 0, 0};
  float domain_hi[3] = {0, 0, 0};
};

struct SeedStepConfig {
  GridLayout grid;
  SeedConstants constants;
  bool near = true;       // near pressure (near_pressure_multiplier > 0)
  bool viscosity = true;  // viscosity > 0
  float gravity_dv = 0;   // m/s, gravity * dt
  float lookahead = 0;    // s, seed::kPredictionLookahead
  std::vector<SphereObstacle> spheres;
  std::vector<BoxObstacle> boxes;
};

// DownloadById, DownloadBelowRank, DownloadViewSubset, DownloadByIds, DownloadPositionBounds,
// size, max_cell_count and GatherProbes are ParticleReadout's.
class SeedPipeline : public ParticleReadout {
 public:
  explicit SeedPipeline(int device);
  ~SeedPipeline();
  SeedPipeline(const SeedPipeline&) = delete;
  SeedPipeline& operator=(const SeedPipeline&) = delete;

  // Sets the constants of the following steps; returns the pass names (as the CPU solver's).
  std::vector<std::string> Configure(const SeedStepConfig& config);
  // Replaces the particles: n ids and n xyz triples (position, velocity), in storage order.
  void Upload(size_t n, const uint32_t* id, const float* position, const float* velocity);
  // Copies the particles back in storage order; any output pointer may be null (not copied).
  // position, velocity, predicted: n xyz triples; the rest n values.
  void Download(uint32_t* id, float* position, float* velocity, float* predicted, float* density,
                float* near_density, float* pressure, float* near_pressure) const;
  // Replaces the obstacles (the configuration's count and order) with where the next step
  // leaves them and their velocity over it: a scene's moving obstacles, each step.
  void MoveObstacles(const std::vector<SphereObstacle>& spheres,
                     const std::vector<BoxObstacle>& boxes);
  StepOutcome Step();
  // On one of several processes (server/distributed), which upload and download their owned
  // particles and ghosts every step: the cell (NeighborGrid::CellIndex) of each particle at the
  // latest sort (by the predicted positions), storage order (size() values); and Upload and
  // Download through page-locked host buffers kept between calls.
  void DownloadSortedCells(uint32_t* cells) const;
  void UsePinnedStaging(bool on);
  // Device memory held, bytes (particles, the grid, the neighbour list, scratch).
  uint64_t DeviceBytes() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dysa::cuda
