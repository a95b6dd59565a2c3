// The mutable state of a simulation: particles as flat arrays, one array per attribute.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "dysa/core/neighbor_grid.h"
#include "dysa/core/types.h"

namespace dysa {

// Particles are physically reordered by grid cell every step, so index i is not a particle's
// identity: id[i] is (its index at spawn time, stable for the whole run).
struct ParticleArrays {
  std::vector<uint32_t> id;
  std::vector<Vec3> position;  // m
  std::vector<Vec3> velocity;  // m/s
  std::vector<Real> density;   // kg/m^3, of the latest step
  std::vector<Real> pressure;  // Pa, of the latest step

  size_t size() const { return id.size(); }
  void Resize(size_t n);
};

// What every solver reads and writes. Each solver keeps the rest itself (Solver, solver.h):
// the seed's near densities, the physical solvers' boundary particles and accelerations,
// dfsph's warm start and pair lists.
struct State {
  ParticleArrays particles;
  NeighborGrid grid;
  // Scratch buffers reused across steps (never shrink, so a step allocates nothing).
  std::vector<Vec3> vec3_scratch;
  std::vector<Real> real_scratch;
  std::vector<uint32_t> index_scratch;

  // s, the step being taken: Model::dt for a fixed-step solver, set before the passes; chosen
  // by a physical solver's time_step pass (CFL), at most max_dt. Both are rewritten every step
  // before they are read, so a checkpoint need not hold them.
  double dt = 0;
  double max_dt = 0;  // s, a cap on this step's dt from the caller (the end of a frame)

  // Set by a pass when its step could not hold the model's accuracy and the pass had to limit
  // it (the seed's velocity limiter, an iteration cap); the run goes on. Cleared at the start of
  // each frame (Simulation::StepFrame) and on reset.
  std::string warning;

  double time = 0;     // s, simulated
  uint64_t step = 0;   // steps since the last reset
  uint64_t frame = 0;  // frames (Simulation::StepFrame) since the last reset
};

// FNV-1a over ids, positions and velocities in id order: equal hashes mean bit-identical
// particle states whatever the storage order.
uint64_t StateHash(const State& state);

// True when every position and velocity is finite. A NaN or Inf means the step diverged; callers
// stop instead of integrating (or showing) garbage.
bool StateIsFinite(const ParticleArrays& particles);

}  // namespace dysa
