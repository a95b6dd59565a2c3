// The wcsph solver's step on a CUDA GPU (solvers/wcsph/becker_teschner_solver.h): the plain
// interface between the host code and the kernels, as seed_pipeline.h.
//
// Each kernel performs the CPU pass's operations in the CPU's order (scalar neighbour loops in
// the grid's fixed order, Eigen's x^2 + (y^2 + z^2) for norms and dot products, no fused
// multiply-add), so the GPU follows the CPU closely; it is not bit-identical because the Tait
// equation's pow() in double is CUDA's (within 2 ulp) and not glibc's, which can move a
// pressure by one float ulp now and then, and a chaotic flow amplifies that.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "cuda/gpu_types.h"
#include "cuda/particle_readout.h"

namespace dysa::cuda {

struct WcsphStepConfig {
  GridLayout grid;  // the fluid's grid; the boundary's has the same layout
  SphConstants constants;
  bool viscosity = false;                  // kinematic_viscosity > 0
  bool wall_viscosity = false;             // and a no-slip wall
  bool artificial_viscosity = false;       // artificial_viscosity > 0
  bool wall_artificial_viscosity = false;  // and a no-slip wall
  bool symplectic = false;  // time_integration = 1: the predictor-corrector (symplectic.h)
  float shifting = 0;       // m, A h of the particle shifting (particle_shifting.h; 0: off)
  float free_surface_divergence = 0;  // its kFreeSurfaceDivergence
  std::vector<SphereObstacle> spheres;
  std::vector<BoxObstacle> boxes;
};

// The boundary particles (BoundaryParticles) in their grid's order: n positions, volumes and
// no-slip flags. With a moving obstacle also, in sampling order, their rest positions, volumes,
// flags and obstacles (-1: a domain wall), which the move_boundary pass places from; empty
// otherwise.
struct BoundaryCloud {
  std::vector<float> x, y, z;
  std::vector<float> volume;  // m^3
  std::vector<uint8_t> no_slip;
  std::vector<float> rest_x, rest_y, rest_z, rest_volume;
  std::vector<uint8_t> rest_no_slip;
  std::vector<int32_t> obstacle;
};

// What the CFL step needs from the particles of this step.
struct StepMaxima {
  float speed2 = 0;         // (m/s)^2, the largest |v|^2
  float acceleration2 = 0;  // (m/s^2)^2, the largest |a|^2
  float density = 0;        // kg/m^3, the largest density
};

// DownloadById, DownloadBelowRank, DownloadViewSubset, DownloadByIds, DownloadPositionBounds,
// size, max_cell_count and GatherProbes are ParticleReadout's.
class WcsphPipeline : public ParticleReadout {
 public:
  explicit WcsphPipeline(int device);
  ~WcsphPipeline();
  WcsphPipeline(const WcsphPipeline&) = delete;
  WcsphPipeline& operator=(const WcsphPipeline&) = delete;

  // Returns the pass names (the CPU solver's).
  std::vector<std::string> Configure(const WcsphStepConfig& config, const BoundaryCloud& boundary);
  // carried_density: the continuity equation's density per particle (n values), or null: it
  // starts at the next step from the positions (InitialDensity).
  void Upload(size_t n, const uint32_t* id, const float* position, const float* velocity,
              const float* carried_density);
  // Any output pointer may be null. position, velocity: n xyz triples.
  void Download(uint32_t* id, float* position, float* velocity, float* density,
                float* pressure) const;
  // The carried density (n values, storage order) into carried_density; false (nothing
  // copied) before it has started.
  bool DownloadCarriedDensity(float* carried_density) const;
  // The passes before the time step (move_boundary with `motion` when the boundary has moving
  // obstacles, neighbour_grid ... wall_viscosity) with gravity `gravity` (m/s^2 along y) and the
  // density diffusion's hydrostatic part -rho0 gravity / c0^2 (kg/m^4), and the time_step
  // pass's maxima.
  StepMaxima Forces(float gravity, float hydrostatic, const ObstacleMotionTable& motion);
  // Replaces the contact's obstacles (the configuration's count and order) with where they are
  // over the coming integration and their velocities, obstacle_speed the largest |u| (m/s).
  void MoveSurfaces(const std::vector<SphereObstacle>& spheres,
                    const std::vector<BoxObstacle>& boxes, float obstacle_speed);
  // The shifting pass where it is on, then the integrate pass with the step dt; the outcome holds
  // every pass's time.
  StepOutcome Integrate(float dt);
  // The predictor-corrector instead of Integrate (symplectic.h): the predict pass with half the
  // step, `half` (m/s^2 and kg/m^4 as Forces, at t + dt/2); the force passes again from the
  // predicted state (CorrectorForces, with the surfaces of the half step still in place); the
  // shifting pass where it is on and the correct pass with the step dt (MoveSurfaces over the
  // whole step first where obstacles move).
  void Predict(float half);
  void CorrectorForces(float gravity, float hydrostatic, const ObstacleMotionTable& motion);
  StepOutcome Correct(float dt);
  uint64_t DeviceBytes() const;

  // On one of several processes (server/distributed), which upload and download their owned
  // particles and ghosts every step:
  // The cell layers along `axis` this process owns, 1 per layer: a particle sorted into another
  // (a ghost) counts as 0 in Forces's maxima, as the CPU's time_step pass skips it (its maxima
  // start at 0). Empty: every particle counts (one process).
  void SetOwnedLayers(int axis, const std::vector<uint8_t>& owned);
  // The cell (NeighborGrid::CellIndex) of each particle at the latest neighbour sort, storage
  // order (size() values).
  void DownloadSortedCells(uint32_t* cells) const;
  // Upload and Download copy through page-locked host buffers kept between calls (a memcpy on
  // the host, then a DMA at the bus's speed), rather than from and into pageable memory.
  void UsePinnedStaging(bool on);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dysa::cuda
