// Pressure solvers, each a named list of passes, registered by name.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "dysa/core/model.h"
#include "dysa/core/state.h"

namespace dysa {

// One named stage of a step. Each pass reads the model and writes the state (and the data of
// the solver that built it); a step runs the passes in order and times each one.
struct Pass {
  std::string name;
  std::function<void(const Model&, State&)> run;
};

// The name of every solver's neighbour sort, after which a step checks that no grid cell holds
// more than NeighborGrid::kMaxParticlesPerCell particles.
inline constexpr std::string_view kNeighbourSortPass = "neighbour_grid";

// The pass `name` of a solver with data of its own: run(model, data, state), the shape
// (const Model&, Data&, State&) of every such pass. `data` belongs to the solver and outlives
// its pass list.
template <class Data, class Run>
Pass SolverPass(std::string name, Data& data, Run run) {
  return {std::move(name), [&data, run](const Model& m, State& s) { run(m, data, s); }};
}

// One per-particle array a solver carries from one step to the next (a warm start), in the
// particles' storage order: a checkpoint holds it, a GPU backend keeps it in device memory.
struct SolverArray {
  std::string name;
  std::vector<Real> values;
};

// Diagnostics of an iterative pressure solver (dfsph): the latest step's iterations and errors,
// and how many solves since the start stopped at max_iterations before reaching their
// tolerance. Zero for the other solvers. Not part of a checkpoint: nothing reads them back.
struct SolverStats {
  int density_iterations = 0;
  int divergence_iterations = 0;
  double density_error = 0;     // mean (rho - rho0) / rho0 at the end of the density solve
  double divergence_error = 0;  // mean (D rho / Dt) dt / rho0 at the end of the divergence solve
  uint64_t capped_solves = 0;
};

// A pressure solver: its passes, and the data it keeps besides the shared State (as
// SPlisHSPlasH's TimeStepDFSPH owns its SimulationDataDFSPH): boundary particles, warm starts,
// pair lists, work arrays. State holds only what every solver reads and writes (the particles,
// the neighbour grid, the step's dt); a GPU backend keeps the same data in device memory
// (gpu_backend.h) behind the same checkpoint hook.
class Solver {
 public:
  virtual ~Solver() = default;
  // The passes of one step for this model: only those it needs (no viscosity pass when the
  // viscosity is 0, no obstacle pass without obstacles, ...). Rebuilt whenever parameters change;
  // rebuilds what the solver derives from the model (its boundary particles). The passes refer
  // to this solver's data: they run while it lives, and until the next BuildPasses.
  virtual std::vector<Pass> BuildPasses(const Model& model) = 0;
  // A cold start for the `particles` just spawned: sizes the per-particle data, warm starts 0.
  virtual void Reset(size_t particles) { (void)particles; }
  // What a checkpoint must hold besides the particles: the arrays the next step reads.
  virtual std::vector<SolverArray> SaveArrays() const { return {}; }
  // Restores SaveArrays()'s arrays for `particles` particles; a missing array or one of another
  // size is a cold start for that array (a checkpoint of a state the solver did not run).
  virtual void RestoreArrays(std::span<const SolverArray> arrays, size_t particles) {
    (void)arrays;
    Reset(particles);
  }
  virtual SolverStats stats() const { return {}; }
  // The positions of the boundary particles it samples (walls, obstacles), for a cost estimate
  // (the step-time balance of server/distributed); none for a solver without them.
  virtual std::vector<Vec3> BoundaryPositions() const { return {}; }
};

// The array named `name` of `arrays` when it holds `size` values, else null.
const std::vector<Real>* FindSolverArray(std::span<const SolverArray> arrays, std::string_view name,
                                         size_t size);

struct SolverInfo {
  std::string_view name;
  std::string_view citation;
  std::unique_ptr<Solver> (*create)();
  // A physical solver works in SI units from the parameters rest_density, particle_spacing,
  // speed_of_sound, ...: fluid blocks are filled at particle_spacing, a particle weighs
  // rest_density * particle_spacing^3, the kernel support is 2 * particle_spacing, and its step
  // is CFL-adaptive (its passes set State::dt). The seed model is not: fixed step Model::dt,
  // its own mass and smoothing radius.
  bool physical = false;
};

std::span<const SolverInfo> SolverRegistry();
// Throws ConfigError("solver", ...) listing the known names.
const SolverInfo& FindSolver(std::string_view name);
std::unique_ptr<Solver> CreateSolver(std::string_view name);
// False for an unknown name.
bool IsPhysicalSolver(std::string_view name);

}  // namespace dysa
