#include <array>

#include "dysa/core/solver.h"
#include "solvers/dfsph/bender_koschier_solver.h"
#include "solvers/seed/seed_solver.h"
#include "solvers/wcsph/becker_teschner_solver.h"

namespace dysa {
namespace {

const std::array kSolvers = {
    SolverInfo{"seed",
               "Clavet, Beaudoin, Poulin 2005, Particle-based viscoelastic fluid simulation "
               "(the DySAQUASIMs thesis model)",
               seed::CreateSeedSolver, /*physical=*/false},
    SolverInfo{"wcsph",
               "Becker, Teschner 2007, Weakly compressible SPH for free surface flows (SCA); "
               "boundaries: Akinci et al. 2012, Versatile rigid-fluid coupling for "
               "incompressible SPH (SIGGRAPH)",
               wcsph::CreateBeckerTeschnerSolver, /*physical=*/true},
    SolverInfo{"dfsph",
               "Bender, Koschier 2015/2017, Divergence-free smoothed particle hydrodynamics "
               "(SCA 2015; IEEE TVCG 2017); boundaries: Akinci et al. 2012",
               dfsph::CreateBenderKoschierSolver, /*physical=*/true},
};

}  // namespace

std::span<const SolverInfo> SolverRegistry() { return kSolvers; }

const std::vector<Real>* FindSolverArray(std::span<const SolverArray> arrays, std::string_view name,
                                         size_t size) {
  for (const SolverArray& array : arrays) {
    if (array.name == name) return array.values.size() == size ? &array.values : nullptr;
  }
  return nullptr;
}

const SolverInfo& FindSolver(std::string_view name) {
  for (const SolverInfo& info : kSolvers) {
    if (info.name == name) return info;
  }
  std::string names;
  for (const SolverInfo& info : kSolvers)
    names += (names.empty() ? "" : ", ") + std::string(info.name);
  throw ConfigError("solver", "unknown solver \"" + std::string(name) + "\"; known: " + names);
}

std::unique_ptr<Solver> CreateSolver(std::string_view name) { return FindSolver(name).create(); }

bool IsPhysicalSolver(std::string_view name) {
  for (const SolverInfo& info : kSolvers) {
    if (info.name == name) return info.physical;
  }
  return false;
}

}  // namespace dysa
