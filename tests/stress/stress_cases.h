// The cases and checks of the numerical stability stress suite, shared by the CI test
// (tests/stress/solver_stress_test.cc, ctest -L stress: 120 steps per case) and its long mode
// (bench/stress_bench.cc: thousands of steps per case).
//
// Every registered solver goes through time steps at and beyond the stability limit, both ends
// of every parameter's range, high-speed impacts, particles started on top of each other, very
// thin and very dense blocks, one particle, no particles, and obstacles overlapping the fluid.
// A run checks, every few steps:
//   - no NaN or Inf in positions and velocities;
//   - no particle outside the domain;
//   - the kinetic energy never above kEnergyMargin times the energy the start can release (its
//     kinetic energy, every particle's drop to the wall gravity pulls it toward, and the work
//     its pressures can do: sum of m |p| / rho after the first step), plus a floor; where the
//     solver says it could not hold its accuracy (Simulation::warning(): an iteration cap, a
//     limiter), kLimitedEnergyMargin times: bounded, never an explosion, and never silent.
// and, every step, that the core never raises its alarm (Simulation::alarm(): a diverged step).
#pragma once

#include <cstdint>
#include <limits>
#include <ostream>
#include <string>
#include <vector>

#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "dysa/core/solver.h"

namespace dysa::stress {

// The stated margin of the energy bound: wall and obstacle collisions, damping and viscosity only
// take energy away, so a factor of 2 over what the start can release leaves room for the
// estimate of the pressure work and for time-integration error, and none for an explosion
// (which grows the energy by orders of magnitude).
constexpr double kEnergyMargin = 2.0;
// A step the solver had to limit (an unconverged solve, particles slowed to the CFL limit) is
// inaccurate by its own account; its energy is still bounded, by this wider margin.
constexpr double kLimitedEnergyMargin = 10.0;
// The floor of the bound, J: a scene with nothing to release (no particles) may still hold 0 J.
constexpr double kEnergyFloor = 1e-9;
// The positions and the energy are checked every this many steps and after the last one; the
// alarm after every step.
constexpr int kCheckEvery = 10;

// Kinetic energy of all particles, J.
double KineticEnergy(const Simulation& sim);
// m |g| times each particle's distance to the wall gravity pulls it toward, J.
double GravityEnergy(const Simulation& sim);
// The work the pressures can do: m times the sum of (|p| + |p_near|) / rho, J.
double PressureWork(const Simulation& sim);

struct Case {
  std::string name;
  Scene scene;
};

// A small block of fluid falling in a closed box, for `solver`: 343 particles for the seed model
// (its basic scene's spacing and parameters), 1,000 for a physical solver (water at 4 cm).
Scene BaseScene(const SolverInfo& solver);

// The particle-count-independent cases of the issue, built from the base scene.
std::vector<Case> Cases(const SolverInfo& solver);

struct StressCase {
  std::string solver;
  Case c;
};

// gtest prints a failing case's parameter; without this, as the bytes of the struct.
void PrintTo(const StressCase& c, std::ostream* os);

// Cases(info) for every registered solver, in registry order.
std::vector<StressCase> AllCases();

// The energy bound and the per-step checks of one run. Construct it before the first step,
// then call AfterStep() after every Simulation::Step().
class StressChecker {
 public:
  explicit StressChecker(const Simulation& sim);

  // Checks the state after step `k` (1 for the first): the alarm always; when `full`, also the
  // finiteness, the domain and the energy bound. Returns the first failure as text, starting
  // with "step k: ", or "" when the step passed.
  std::string AfterStep(const Simulation& sim, int k, bool full);

  // What the start can release, J (known after the first step).
  double released() const { return released_; }
  // The bound on the kinetic energy after the latest step, J.
  double bound() const;
  // Whether the solver warned (Simulation::warning() non-empty) after any step so far.
  bool warned() const { return warned_; }
  // The largest kinetic energy over the bound at a checked step (0 before one; above 1 fails).
  double max_energy_ratio() const { return max_energy_ratio_; }

 private:
  double start_energy_ = 0;  // kinetic and gravity energy before the first step, J
  double released_ = 0;
  bool warned_ = false;
  double max_energy_ratio_ = 0;
};

struct RunOptions {
  int steps = 120;  // at most this many steps
  // Stops earlier once the simulated time reaches this (s; physical solvers land on it exactly).
  double until = std::numeric_limits<double>::infinity();
};

struct RunResult {
  int steps = 0;      // steps run (up to and including a failing one)
  double time = 0;    // simulated time reached, s
  double wall_s = 0;  // wall-clock time of the steps and checks, s
  size_t particles = 0;
  double max_energy_ratio = 0;  // StressChecker::max_energy_ratio()
  bool warned = false;
  // The first failure, "" when none: "step k: " and a NaN or Inf, a particle outside the domain
  // (its id and position), the alarm's text, or the kinetic energy over the bound.
  std::string failure;

  bool ok() const { return failure.empty(); }
};

// Runs `scene` through the checks, stopping at the first failure. Step k is checked in full when
// k is a multiple of kCheckEvery and after the last step. Throws what Simulation's constructor
// throws (ConfigError) for an invalid scene.
RunResult RunCase(const Scene& scene, const RunOptions& options = {});

}  // namespace dysa::stress
