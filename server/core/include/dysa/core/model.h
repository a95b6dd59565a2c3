// The read-only side of a step: parameters and geometry. Passes take (const Model&, State&).
#pragma once

#include <vector>

#include "dysa/core/kernels.h"
#include "dysa/core/params.h"
#include "dysa/core/scene.h"
#include "dysa/core/types.h"

namespace dysa {

struct Model {
  Params params;
  Aabb domain;                    // m; the walls of the box the fluid is kept in
  Periodicity periodic{};         // axes that wrap around instead (no walls there)
  std::array<bool, 3> no_slip{};  // axes whose walls hold the fluid at rest (else free-slip)
  std::vector<SphereObstacle> spheres;
  std::vector<BoxObstacle> boxes;
  double dt = 0;  // s, the step: time_scale / (frame_rate * iterations_per_frame)

  // Solver-dependent constants (see SolverInfo::physical). The seed model: its particle_mass
  // and smoothing_radius, fixed step dt. A physical solver: rest_density * particle_spacing^3,
  // the support 2 h = 2 smoothing_length_ratio particle_spacing of its kernel, and an adaptive
  // step (State::dt) of at most max_time_step; a frame is then time_scale / frame_rate
  // simulated seconds.
  bool physical = false;
  double particle_mass = 1;   // kg
  double kernel_support = 0;  // m, the kernel's radius
  // The neighbour grid's cells per support (its cell edge: kernel_support / this; NeighborGrid's
  // reach): Params::grid_cells_per_support for a physical solver, 1 for seed.
  int grid_cells_per_support = 1;
  KernelKind kernel_kind = KernelKind::kCubicSpline;  // a physical solver's kernel
  // A physical solver's kernel gradient moment on the rest lattice, LatticeGradientMoment
  // (kernels.h); the pressure gradients are divided by it so that hydrostatic equilibrium holds
  // with p = rho g (H - y). 1 for the seed model.
  double gradient_moment = 1;
  // Likewise its viscosity moment, LatticeViscosityMoment: the laminar viscosity terms are
  // divided by it, so that kinematic_viscosity is the fluid's viscosity. 1 for seed.
  double viscosity_moment = 1;
  // And its density moment, LatticeDensityMoment where above 1 (else 1): summation densities
  // are divided by it and boundary volumes multiplied, so that the rest lattice is not read as
  // compressed. 1 for seed and the cubic spline at 2 d.
  double density_moment = 1;

  // A physical solver's kernel in precision T.
  template <class T = Real>
  PhysicalKernel<T> Kernel() const {
    return {kernel_kind, T(kernel_support)};
  }
  // m, the smoothing length h = support / 2 (a physical solver).
  double SmoothingLength() const { return 0.5 * kernel_support; }

  // Simulated seconds per displayed frame (the same for both kinds of solver).
  double FrameTime() const { return params.time_scale / params.frame_rate; }

  bool HasObstacles() const { return !spheres.empty() || !boxes.empty(); }
  // Whether any obstacle has a prescribed motion (ObstacleMotion): only then do the solvers
  // move boundaries, so a static scene steps exactly as before motions existed.
  bool HasMovingObstacles() const {
    for (const BoxObstacle& b : boxes)
      if (b.motion.moving()) return true;
    for (const SphereObstacle& s : spheres)
      if (s.motion.moving()) return true;
    return false;
  }
  bool HasNoSlipWalls() const { return no_slip[0] || no_slip[1] || no_slip[2]; }

  // The separation d = x_a - x_b of two points taken to the nearest image across the periodic
  // axes (each such component in [-L/2, L/2]); unchanged along the others.
  template <class V>
  V MinimumImage(V d) const {
    for (int a = 0; a < 3; ++a) {
      if (!periodic[a]) continue;
      const auto length = typename V::Scalar(domain.max[a] - domain.min[a]);
      if (d[a] > length / 2) d[a] -= length;
      if (d[a] < -length / 2) d[a] += length;
    }
    return d;
  }
};

struct SolverInfo;

// The model of `scene` with `params` for `solver`, the scene's solver as the caller looked it
// up once (FindSolver(scene.solver)). Throws ConfigError where a periodic axis is too short for
// the parameters (CheckPeriodicDomain).
Model MakeModel(const Scene& scene, const Params& params, const SolverInfo& solver);
// The same, looking scene.solver up (throws ConfigError("solver", ...) for an unknown name).
Model MakeModel(const Scene& scene, const Params& params);

}  // namespace dysa
