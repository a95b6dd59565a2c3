// Numerical stability, long mode: the stress suite's cases (tests/stress/stress_cases.h: every
// registered solver through time steps at and beyond the stability limit, both ends of every
// parameter's range, high-speed impacts, coincident particles, a thin sheet, a dense block, 1
// and 0 particles, obstacles inside the fluid) for many more steps than ctest -L stress runs
// (120), with the same checks: no NaN or Inf, no particle outside the domain, no alarm, kinetic
// energy within its bound. Writes bench/results/stress_long.csv; the exit status is 1 if any
// case failed (a finding: the line and the CSV say which step and what went wrong).
//
//   build/release/bench/stress_bench [--steps 2000] [--until SECONDS] [--solvers seed,dfsph]
//                                    [--case REGEX] [--threads 2] [--out bench/results]
//
// On a shared machine, run it with OMP_WAIT_POLICY=PASSIVE as the tests are: the scenes are
// small, and spinning threads wait at every barrier for a core another job holds (bench/README.md).
#include <omp.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <limits>
#include <regex>
#include <string>
#include <vector>

#include "dysa/core/solver.h"
#include "stress/stress_cases.h"

namespace {

struct Row {
  std::string solver, case_name;
  dysa::stress::RunResult result;
};

// A CSV field: quoted when it holds a comma, a quote or a line break (the failure text can).
std::string CsvField(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (const char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"The stress suite's cases for every solver, run for many steps"};
  int steps = 2000, threads = 2;
  double until = std::numeric_limits<double>::infinity();
  std::vector<std::string> solvers;
  std::string case_regex = ".*";
  std::string out_dir = "bench/results";
  app.add_option("--steps", steps, "Steps per case (ctest -L stress runs 120)")
      ->check(CLI::Range(1, 100000000))
      ->capture_default_str();
  app.add_option("--until", until, "Also stop a case at this simulated time (s)")
      ->check(CLI::PositiveNumber);
  app.add_option("--solvers", solvers, "Solvers (default: every registered one)")->delimiter(',');
  app.add_option("--case", case_regex, "Only the cases whose name matches this regex (search)")
      ->capture_default_str();
  app.add_option("--threads", threads, "OpenMP threads")->check(CLI::Range(1, 1024));
  app.add_option("--out", out_dir, "Directory for stress_long.csv")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  omp_set_num_threads(threads);

  try {
    if (solvers.empty()) {
      for (const dysa::SolverInfo& info : dysa::SolverRegistry()) solvers.emplace_back(info.name);
    }
    const std::regex filter(case_regex);
    std::vector<dysa::stress::StressCase> cases;
    for (const std::string& solver : solvers) {
      for (dysa::stress::Case& c : dysa::stress::Cases(dysa::FindSolver(solver))) {
        if (std::regex_search(c.name, filter)) cases.push_back({solver, std::move(c)});
      }
    }
    if (cases.empty()) {
      std::fprintf(stderr, "stress_bench: no case matches --case '%s'\n", case_regex.c_str());
      return 2;
    }
    std::filesystem::create_directories(out_dir);
    const std::filesystem::path csv_path = std::filesystem::path(out_dir) / "stress_long.csv";
    std::ofstream csv(csv_path);
    csv << "solver,case,particles,steps,sim_time_s,wall_s,max_ke_over_bound,warned,status,"
           "reason\n";
    std::printf("%zu cases, at most %d steps each, %d threads\n", cases.size(), steps, threads);
    std::printf("%-6s %-28s %9s %7s %11s %8s %10s %6s  %s\n", "solver", "case", "particles",
                "steps", "sim time s", "wall s", "KE/bound", "warned", "status");
    const auto start = std::chrono::steady_clock::now();
    std::vector<Row> rows;
    for (const dysa::stress::StressCase& c : cases) {
      Row row{c.solver, c.c.name, {}};
      try {
        row.result = dysa::stress::RunCase(c.c.scene, {.steps = steps, .until = until});
      } catch (const std::exception& e) {
        row.result.failure = std::string("exception: ") + e.what();
      }
      const dysa::stress::RunResult& r = row.result;
      std::printf("%-6s %-28s %9zu %7d %11.4g %8.2f %10.4f %6s  %s%s\n", c.solver.c_str(),
                  c.c.name.c_str(), r.particles, r.steps, r.time, r.wall_s, r.max_energy_ratio,
                  r.warned ? "yes" : "no", r.ok() ? "ok" : "FAIL: ", r.failure.c_str());
      std::fflush(stdout);
      csv << c.solver << ',' << CsvField(c.c.name) << ',' << r.particles << ',' << r.steps << ','
          << r.time << ',' << r.wall_s << ',' << r.max_energy_ratio << ','
          << (r.warned ? "yes" : "no") << ',' << (r.ok() ? "ok" : "FAIL") << ','
          << CsvField(r.failure) << '\n';
      csv.flush();
      rows.push_back(std::move(row));
    }
    const double total_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

    size_t passed = 0, warned = 0;
    const Row* largest = nullptr;     // over every case
    const Row* largest_ok = nullptr;  // over the cases that passed
    const Row* slowest = nullptr;
    for (const Row& row : rows) {
      passed += row.result.ok();
      warned += row.result.warned;
      if (!largest || row.result.max_energy_ratio > largest->result.max_energy_ratio) {
        largest = &row;
      }
      if (row.result.ok() &&
          (!largest_ok || row.result.max_energy_ratio > largest_ok->result.max_energy_ratio)) {
        largest_ok = &row;
      }
      if (!slowest || row.result.wall_s > slowest->result.wall_s) slowest = &row;
    }
    std::printf("\n%zu cases: %zu passed, %zu failed; %zu warned (bound %gx instead of %gx)\n",
                rows.size(), passed, rows.size() - passed, warned,
                dysa::stress::kLimitedEnergyMargin, dysa::stress::kEnergyMargin);
    std::printf("largest kinetic energy / bound: %.4f (%s %s)\n", largest->result.max_energy_ratio,
                largest->solver.c_str(), largest->case_name.c_str());
    if (largest_ok && largest_ok != largest) {
      std::printf("largest of the cases that passed: %.4f (%s %s)\n",
                  largest_ok->result.max_energy_ratio, largest_ok->solver.c_str(),
                  largest_ok->case_name.c_str());
    }
    std::printf("slowest case: %s %s, %.1f s; all cases %.1f s\n", slowest->solver.c_str(),
                slowest->case_name.c_str(), slowest->result.wall_s, total_s);
    for (const Row& row : rows) {
      if (!row.result.ok()) {
        std::printf("FAILED: %s %s: %s\n", row.solver.c_str(), row.case_name.c_str(),
                    row.result.failure.c_str());
      }
    }
    std::printf("wrote %s\n", csv_path.c_str());
    return passed == rows.size() ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "stress_bench: error: %s\n", e.what());
    return 2;
  }
}
