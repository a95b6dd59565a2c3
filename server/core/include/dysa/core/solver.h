// Pressure solvers, each a named list of passes, registered by name.
#pragma once

#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "dysa/core/model.h"
#include "dysa/core/state.h"

namespace dysa {

// One named stage of a step. Each pass reads the model and writes the state; a step runs the
// passes in order and times each one.
struct Pass {
  std::string name;
  std::function<void(const Model&, State&)> run;
};

class Solver {
 public:
  virtual ~Solver() = default;
  // The passes of one step for this model: only those it needs (no viscosity pass when the
  // viscosity is 0, no obstacle pass without obstacles, ...). Rebuilt whenever parameters change.
  virtual std::vector<Pass> BuildPasses(const Model& model) const = 0;
  // Sizes what the solver carries from one step to the next besides positions and velocities
  // (ParticleArrays::density_stiffness, ...), after the particles were spawned.
  virtual void InitState(State&) const {}
};

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
