// The mutable state of a simulation: particles as flat arrays, one array per attribute.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "dysa/core/neighbor_grid.h"
#include "dysa/core/types.h"

namespace dysa {

class DeviceGhostExchange;  // device_ghost_exchange.h

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

// Where a State is one process's part of a simulation spread over several (server/distributed):
// besides the particles it owns it holds ghosts, copies of the particles of other processes
// that its own particles' neighbour loops read. The passes compute ghosts like any particle
// (their results are wrong near the ghosts' far edge and are thrown away), except a last pass
// whose results no neighbour reads, which may skip them (wcsph's interactions, shifting and
// integration); a reduction that steers the step (the CFL step's maxima) must skip them and
// combine over the processes.
// Default: one process, no ghosts.
struct ProcessShare {
  // Per particle in storage order (the order after the neighbour sort): 0 for an owned
  // particle, else a ghost's distance in cell layers from this process's slab (1-255). Empty
  // when there are none.
  std::vector<uint8_t> ghost;
  // Ghosts up to this distance have their rates computed too (wcsph's interactions): the
  // predictor-corrector reads their predicted state after its second sort. 0: none.
  uint8_t rate_reach = 0;
  // Replaces each value by its maximum over all processes (exact, so order-free); null on one
  // process.
  std::function<void(std::span<double>)> max_over_processes;
  // Replaces each value by its sum over all processes (integers: exact, so order-free; a
  // floating-point sum is made one by fixed_point_sum.h); null on one process.
  std::function<void(std::span<int64_t>)> sum_over_processes;
  // Replaces every ghost's entry of a per-particle array (storage order, one entry per particle
  // held) by its owner's value: for a solver whose iterations read their neighbours' values of
  // the previous iteration (dfsph's pressure solves), which no ghost layer of fixed depth could
  // compute locally. Valid between the neighbour sort and the end of the step (the ghosts and
  // their order stay put); null on one process and for solvers that do not need it.
  std::function<void(std::span<Vec3>)> refresh_ghosts;
  // The same for a step that runs on a device (StepBackend: the particles are in its memory, not
  // in these arrays): the device reads back its owned particles' values that others read, this
  // hook exchanges them, and the device writes its ghosts' (device_ghost_exchange.h). Set by the
  // driver for a solver that refreshes its ghosts; null otherwise. Not owned.
  DeviceGhostExchange* device_ghosts = nullptr;
  // The grid's cell layers along axis `layer_axis` whose boundary particles this process's own
  // particles read (those within a cell of its slab), 1 per layer; empty: all. A pass over the
  // boundary particles may skip the others (their values are read only by other processes).
  int layer_axis = 0;
  std::vector<uint8_t> boundary_layers;
  // For a step that sorts where the host cannot set `ghost` (a GPU: StepBackend): 1 per cell
  // layer along `layer_axis` that this process owns; a particle sorted into another layer is a
  // ghost, left out of the step's maxima. Empty: every particle is owned (one process).
  std::vector<uint8_t> owned_layers;

  bool IsGhost(size_t i) const { return !ghost.empty() && ghost[i] != 0; }
  // Null when there are no ghosts: the skip flags of a reduction over the owned particles.
  const uint8_t* GhostFlags() const { return ghost.empty() ? nullptr : ghost.data(); }
  // The hooks above, doing nothing on one process (collective on several: every process must
  // call them in the same order).
  void MaxOverProcesses(std::span<double> values) const {
    if (max_over_processes) max_over_processes(values);
  }
  void SumOverProcesses(std::span<int64_t> values) const {
    if (sum_over_processes) sum_over_processes(values);
  }
  void RefreshGhosts(std::span<Vec3> values) const {
    if (refresh_ghosts) refresh_ghosts(values);
  }
  // Whether a pass whose results only neighbours within rate_reach read skips particle i.
  bool SkipsRates(size_t i) const { return !ghost.empty() && ghost[i] > rate_reach; }
  bool NeedsBoundaryCell(const Eigen::Vector3i& cell) const {
    return boundary_layers.empty() || boundary_layers[size_t(cell[layer_axis])] != 0;
  }
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
  ProcessShare share;

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
