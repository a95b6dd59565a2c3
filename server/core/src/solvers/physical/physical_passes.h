// What the physical solvers (wcsph, dfsph) share: the gravity ramp, the neighbour sort, the
// laminar viscosity of the fluid and of no-slip walls, and the inelastic wall contact. Each
// solver's header describes the discretisation (becker_teschner_solver.h); the CPU passes are
// here, and the GPU backend reads the same constants.
#pragma once

#include <span>
#include <vector>

#include "dysa/core/model.h"
#include "dysa/core/params.h"
#include "dysa/core/state.h"
#include "solvers/physical/physical_data.h"

namespace dysa::physical {

// gamma of the Tait equation of state, p = B ((rho / rho0)^gamma - 1) (Becker & Teschner 2007,
// eq. 7): wcsph's pressure, and the speed of sound of the CFL step (cfl_time_step.h).
inline constexpr double kTaitExponent = 7;
// m/s^2 along y at simulated time `time`: params.gravity, ramped in over gravity_ramp_time,
// g(t) = g (1 - cos(pi t / T)) / 2 for t < T, g after (T = 0: no ramp).
double GravityAt(const Params& params, double time);

// The `neighbour_grid` pass: sorts the particles by grid cell (cell edge = the kernel support)
// of their positions and reorders ids, positions and velocities into that order.
void SortIntoGrid(const Model& model, State& state);

// Adds the fluid's viscous acceleration (the laminar viscosity of becker_teschner_solver.h) to
// data.acceleration.
void AddViscosity(const Model& model, PhysicalData& data, State& state);
// data.boundary_velocity: at each no-slip wall's boundary particle the fluid's velocity
// extrapolated to it and mirrored (Shepard mean, negated), 0 elsewhere.
void ExtrapolateWallVelocity(const Model& model, PhysicalData& data, State& state);
// Adds the no-slip walls' viscous acceleration (Model::no_slip) to data.acceleration, from the
// fluid's velocity extrapolated to the walls' boundary particles (ExtrapolateWallVelocity).
void AddWallViscosity(const Model& model, PhysicalData& data, State& state);

// Each obstacle's frame (boxes, then spheres, as the Model lists them) for the step [t, t + dt]:
// its displacement at t and its mean velocity over the step, (D(t + dt) - D(t)) / dt, so that
// the contact below sees where the step really takes it. Empty when no obstacle moves.
std::vector<ObstacleFrame> ObstacleFramesOverStep(const Model& model, double t, double dt);

// The `move_boundary` pass, first in a step of a scene with a moving obstacle: moves the
// obstacles' boundary samples to their displacement at the step's start time (state.time) and
// gives them the velocity there (ObstacleMotion::VelocityAt), which the density and pressure
// passes read; sets data.max_obstacle_speed.
void MoveBoundary(const Model& model, PhysicalData& data, State& state);

// The wall contact: limits v so that a step of dt from x brings the particle no closer than
// r0 / 2 (r0 = Params::wall_contact_range spacings) to any wall or obstacle, cutting only its
// velocity towards the surface (an inelastic contact: energy is only taken away). With `frames`
// (ObstacleFramesOverStep; empty: every obstacle static) an obstacle is taken at its displacement
// and only the velocity relative to it is cut: a moving obstacle pushes the fluid ahead of it.
void LimitApproachToSurfaces(const Model& model, std::span<const ObstacleFrame> frames, Real dt,
                             const Vec3& x, Vec3& v);

}  // namespace dysa::physical
