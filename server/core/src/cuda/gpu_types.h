// Plain types shared by the CUDA pipelines and the host code that drives them (no Eigen, no
// CUDA headers: both compilers read this).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace dysa::cuda {

// A NeighborGrid's layout (neighbor_grid.h), as the host computed it.
struct GridLayout {
  double origin[3] = {0, 0, 0};    // m
  double inv_cell[3] = {1, 1, 1};  // 1/m
  int dims[3] = {1, 1, 1};
  int reach = 1;  // cells either side a run query visits (NeighborGrid::reach)
  bool periodic[3] = {false, false, false};
  float period[3] = {0, 0, 0};  // m, the domain's length along each periodic axis
};

// An obstacle where the current step has it (ObstacleMotion: the host places it each step when
// it moves) and its velocity over the step, 0 for a static one.
struct SphereObstacle {
  float center[3];
  float radius;
  float velocity[3] = {0, 0, 0};  // m/s
};
struct BoxObstacle {
  float lo[3];
  float hi[3];
  float velocity[3] = {0, 0, 0};  // m/s
};

// The obstacles' displacements from the scene's positions and their velocities at a step's
// start (the move_boundary pass): 3 floats per obstacle, boxes then spheres as in the Model.
struct ObstacleMotionTable {
  std::vector<float> offset;    // m
  std::vector<float> velocity;  // m/s
};

// The constants of the physical solvers (wcsph, dfsph) their kernels read, computed on the host
// as the CPU passes compute them.
// SphConstants::kernel: KernelKind (kernels.h) as an int the device code compares.
constexpr int kCubicSpline = 0;
constexpr int kWendlandC2 = 1;

struct SphConstants {
  int kernel = kCubicSpline;        // the smoothing kernel (Params::kernel)
  float support = 0;                // m, the kernel's support 2 h
  float mass = 0;                   // kg, rho0 d^3
  float psi_scale = 0;              // kg/m^3, rho0: Psi_b = rho0 V_b
  float density_scale = 1;          // 1 / the lattice's density moment
  float gradient_scale = 0;         // 1 / the lattice's gradient moment
  float viscosity_scale = 0;        // 2 (dim + 2) nu m / lambda
  float wall_viscosity_scale = 0;   // 2 (dim + 2) nu / lambda
  float eps = 0;                    // m^2, 0.01 h^2
  double rest_density = 0;          // kg/m^3
  double stiffness = 0;             // Pa, B = rho0 c0^2 / gamma
  float contact_range = 0;          // m, r0 (LimitApproachToSurfaces)
  float diffusion = 0;              // m^2/s, wcsph's delta h c0 (density_diffusion)
  float artificial_scale = 0;       // kg m^2/s, wcsph's 2 alpha c0 h m (artificial_viscosity)
  float wall_artificial_scale = 0;  // m^2/s, and its alpha c0 h at the no-slip walls
  float density_min = 0;            // kg/m^3, wcsph's carried density range (carried_density_min)
  float density_max = 0;            // kg/m^3, (kCarriedDensityMax)
  float domain_lo[3] = {0, 0, 0};
  float domain_hi[3] = {0, 0, 0};
};

struct GpuProperties {
  std::string name;
  uint64_t memory_bytes = 0;
  int compute_capability = 0;
};

// Empty when CUDA device `index` can be used (and fills `props`); otherwise why not.
std::string ProbeCudaDevice(int index, GpuProperties* props);

struct StepOutcome {
  std::vector<double> pass_ms;  // per pass of PassNames(), from CUDA events
  bool finite = true;           // every position and velocity finite after the step
  uint64_t limited = 0;         // particles the velocity limiter slowed
};

}  // namespace dysa::cuda
