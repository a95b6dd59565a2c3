// What both physical solvers (wcsph, dfsph) keep besides the shared State: the boundary
// particles of the current model and the step's accelerations. Each solver's own data extends
// it (BeckerTeschnerData, BenderKoschierData). Nothing here outlives a step except the boundary
// particles, which depend on the model only: a checkpoint holds none of it.
#pragma once

#include <memory>
#include <vector>

#include "dysa/core/model.h"
#include "dysa/core/types.h"
#include "solvers/physical/boundary_particles.h"

namespace dysa::physical {

// An obstacle's place and speed over one step (ObstacleMotion): its displacement from the
// scene's position at the step's start, and its velocity.
struct ObstacleFrame {
  Vec3d displacement = Vec3d::Zero();  // m
  Vec3 velocity = Vec3::Zero();        // m/s
};

struct PhysicalData {
  // The walls and obstacles of the model the pass list was built for (Solver::BuildPasses);
  // the move_boundary pass moves a moving obstacle's samples each step.
  std::unique_ptr<BoundaryParticles> boundary;
  // m/s, the fastest obstacle this step (move_boundary): the CFL step keeps a boundary sample
  // from crossing more of a spacing per step than a fluid particle may. 0 without motions.
  double max_obstacle_speed = 0;
  // m/s^2, per particle in storage order: this step's accelerations, computed after the
  // neighbour sort.
  std::vector<Vec3> acceleration;
  // m/s, per boundary particle of a no-slip wall: the fluid's velocity extrapolated to it,
  // mirrored (so that the velocity falls to 0 at the wall); 0 elsewhere. Per step.
  std::vector<Vec3> boundary_velocity;
  // m/s, per particle: the particle shifting's displacement rate (particle_shifting.h), which
  // the integration adds to the velocity's; computed by the `shifting` pass where it is on.
  std::vector<Vec3> shift;

  // Samples the boundary particles of `model` at its particle spacing and kernel support.
  void SampleBoundary(const Model& model) {
    boundary = std::make_unique<BoundaryParticles>(model, model.params.particle_spacing,
                                                   model.kernel_support);
  }
};

}  // namespace dysa::physical
