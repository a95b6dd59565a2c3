// The wording of dfsph's step warnings (bender_koschier_solver.h), shared by the CPU solver and
// the GPU backend.
#include <cstdint>
#include <cstdio>
#include <string>

#include "solvers/dfsph/bender_koschier_solver.h"

namespace dysa::dfsph {

// The diagnostic of a solve that stopped at its iteration cap: the error it could not bring
// under the tolerance is then carried into the step, instead of passing as converged.
std::string CapWarning(const char* solve, int iterations, double error, double tolerance,
                       uint64_t step) {
  char text[320];
  std::snprintf(text, sizeof text,
                "dfsph: the %s solve stopped at max_iterations = %d with a mean error of %.3g%% "
                "(tolerance %.3g%%) at step %llu; lower cfl_factor or max_time_step, or raise "
                "max_iterations",
                solve, iterations, 100 * error, 100 * tolerance, (unsigned long long)step);
  return text;
}

std::string SpeedLimitWarning(uint64_t limited, uint64_t step) {
  return "dfsph: " + std::to_string(limited) +
         " particles would have moved more than particle_spacing in step " + std::to_string(step) +
         " and were slowed to it; the step is beyond the solver's stability limit (lower "
         "cfl_factor or max_time_step, or raise max_iterations)";
}

}  // namespace dysa::dfsph
