// Numerical stability stress suite (ctest -L stress): every registered solver through the edge
// cases of tests/stress/stress_cases.h (time steps at and beyond the stability limit, both ends
// of every parameter's range, high-speed impacts, particles started on top of each other, very
// thin and very dense blocks, one particle, no particles, and obstacles overlapping the fluid),
// 120 steps each. Every case asserts, every few steps:
//   - no NaN or Inf in positions and velocities;
//   - no particle outside the domain;
//   - the kinetic energy never above kEnergyMargin times the energy the start can release (its
//     kinetic energy, every particle's drop to the wall gravity pulls it toward, and the work
//     its pressures can do: sum of m |p| / rho after the first step), plus a floor; where the
//     solver says it could not hold its accuracy (Simulation::warning(): an iteration cap, a
//     limiter), kLimitedEnergyMargin times: bounded, never an explosion, and never silent.
// and the core never raises its alarm (Simulation::alarm(): a diverged step). The checks are
// dysa::stress::StressChecker's, shared with the long mode (bench/stress_bench.cc).
#include <gtest/gtest.h>

#include <cctype>
#include <string>

#include "stress/stress_cases.h"

namespace dysa::stress {
namespace {

class SolverStressTest : public ::testing::TestWithParam<StressCase> {};

TEST_P(SolverStressTest, StaysFiniteInsideTheDomainAndEnergyBounded) {
  constexpr int kSteps = 120;
  const RunResult result = RunCase(GetParam().c.scene, RunOptions{.steps = kSteps});
  // The failure says the step and what went wrong: the alarm's text, a NaN or Inf, the particle
  // outside the domain and where, or the kinetic energy against its bound and the warning.
  ASSERT_TRUE(result.ok()) << result.failure;
}

INSTANTIATE_TEST_SUITE_P(AllSolvers, SolverStressTest, ::testing::ValuesIn(AllCases()),
                         [](const ::testing::TestParamInfo<StressCase>& param_info) {
                           const StressCase& c = param_info.param;
                           std::string name = c.solver + "_" + c.c.name;
                           for (char& ch : name) {
                             if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
                           }
                           return name;
                         });

}  // namespace
}  // namespace dysa::stress
