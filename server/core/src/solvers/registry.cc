#include <array>

#include "dysa/core/solver.h"
#include "solvers/seed/seed_solver.h"

namespace dysa {
namespace {

const std::array kSolvers = {
    SolverInfo{"seed",
               "Clavet, Beaudoin, Poulin 2005, Particle-based viscoelastic fluid simulation "
               "(the DySAQUASIMs thesis model)",
               seed::CreateSeedSolver},
};

}  // namespace

std::span<const SolverInfo> SolverRegistry() { return kSolvers; }

std::unique_ptr<Solver> CreateSolver(std::string_view name) {
  for (const SolverInfo& info : kSolvers) {
    if (info.name == name) return info.create();
  }
  std::string names;
  for (const SolverInfo& info : kSolvers)
    names += (names.empty() ? "" : ", ") + std::string(info.name);
  throw ConfigError("solver", "unknown solver \"" + std::string(name) + "\"; known: " + names);
}

}  // namespace dysa
