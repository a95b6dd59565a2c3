// What a scene does not need costs nothing: time per step of every solver with viscosity,
// obstacles and near pressure on, each one off, and all off (the pass list drops the passes a
// scene does not need); and the steps the CFL-adaptive time step saves on the dam break against
// the fixed worst-case step. Writes bench/results/pass_skipping.csv and adaptive_steps.csv.
//
//   build/release/bench/pass_skipping_bench [--threads 2] [--steps 60] [--repeats 3]
//                                           [--set NAME=VALUE ...]
//
// Scenes: the thesis's obstacle scene (seed_obstacles: a sphere and a box in the falling fluid)
// for the seed model; for a physical solver the same obstacles and fluid block at a particle
// spacing that gives a similar particle count. "Off" means: viscosity 0, near pressure
// multiplier 0 (seed only), no obstacles.
#include <omp.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "dysa/core/params.h"
#include "dysa/core/simulation.h"
#include "dysa/core/solver.h"
#include "dysa/validation/validation.h"

namespace {

struct Feature {
  std::string name;
  // Turns the feature off in `scene`; false if the solver has no such feature.
  bool (*off)(dysa::Scene& scene, bool physical);
};

bool ViscosityOff(dysa::Scene& scene, bool physical) {
  dysa::SetParam(scene.params, physical ? "kinematic_viscosity" : "viscosity", 0.0);
  return true;
}
bool NearPressureOff(dysa::Scene& scene, bool physical) {
  if (physical) return false;  // the physical solvers have no near pressure
  dysa::SetParam(scene.params, "near_pressure_multiplier", 0.0);
  return true;
}
bool ObstaclesOff(dysa::Scene& scene, bool) {
  scene.spheres.clear();
  scene.boxes.clear();
  return true;
}

const std::vector<Feature> kFeatures = {
    {"viscosity", ViscosityOff}, {"near_pressure", NearPressureOff}, {"obstacles", ObstaclesOff}};

// The obstacle scene for `solver`. A physical solver fills the block at particle_spacing,
// chosen as the seed block's spacing (3 m / 18 particles), so the counts match.
dysa::Scene SceneFor(const dysa::SolverInfo& solver) {
  dysa::Scene scene = dysa::LoadScene("seed_obstacles");
  scene.solver = std::string(solver.name);
  if (solver.physical) {
    for (dysa::FluidBlock& block : scene.fluid_blocks) block.particles_per_axis.reset();
    dysa::SetParam(scene.params, "particle_spacing", 3.0 / 18);
    dysa::SetParam(scene.params, "kinematic_viscosity", 1e-3);
  }
  return scene;
}

struct Timing {
  double ms_per_step = 0;  // the fastest of the repeats
  // Of that run: the iterative pressure solves' time per step (dfsph's divergence_solve and
  // density_solve passes; 0 for the other solvers) and their iterations per step. Their work
  // depends on the flow each configuration makes, not on which passes it runs.
  double solve_ms_per_step = 0;
  double iterations_per_step = 0;
  size_t particles = 0;
  std::vector<std::string> passes;
};

Timing Measure(const dysa::Scene& scene, int warmup, int steps, int repeats) {
  Timing t;
  t.ms_per_step = 1e30;
  for (int r = 0; r < repeats; ++r) {
    dysa::Simulation sim(scene);
    for (int i = 0; i < warmup; ++i) sim.Step();
    sim.ResetProfile();
    uint64_t iterations = 0;
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < steps; ++i) {
      sim.Step();
      iterations += uint64_t(sim.solver_stats().density_iterations +
                             sim.solver_stats().divergence_iterations);
    }
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
            .count() /
        steps;
    if (ms >= t.ms_per_step) continue;
    t.ms_per_step = ms;
    t.solve_ms_per_step = 0;
    for (const dysa::PassProfile& pass : sim.profile()) {
      if (pass.name == "divergence_solve" || pass.name == "density_solve") {
        t.solve_ms_per_step += pass.total_ms / steps;
      }
    }
    t.iterations_per_step = double(iterations) / steps;
    t.particles = sim.particle_count();
    t.passes = sim.PassNames();
  }
  return t;
}

std::string Join(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& n : names) out += (out.empty() ? "" : " ") + n;
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Time per step with the optional physics on and off, for every solver"};
  int threads = 2, warmup = 30, steps = 60, repeats = 3;
  std::string out_dir = "bench/results";
  app.add_option("--threads", threads, "OpenMP threads")->check(CLI::Range(1, 1024));
  app.add_option("--warmup", warmup, "Steps before timing")->check(CLI::Range(0, 100000));
  app.add_option("--steps", steps, "Timed steps")->check(CLI::Range(1, 100000));
  app.add_option("--repeats", repeats, "Runs per configuration (the fastest counts)")
      ->check(CLI::Range(1, 100));
  app.add_option("--out", out_dir, "Directory for pass_skipping.csv")->capture_default_str();
  std::vector<std::string> sets;
  app.add_option("--set", sets, "NAME=VALUE parameter for every scene (as dysa run --set)");
  CLI11_PARSE(app, argc, argv);
  omp_set_num_threads(threads);

  try {
    std::filesystem::create_directories(out_dir);
    std::ofstream csv(std::filesystem::path(out_dir) / "pass_skipping.csv");
    csv << "solver,configuration,particles,threads,ms_per_step,speedup_vs_all_on,solve_ms_per_step,"
           "solver_iterations_per_step,passes\n";
    for (const dysa::SolverInfo& solver : dysa::SolverRegistry()) {
      dysa::Scene all_on = SceneFor(solver);
      for (const std::string& assignment : sets)
        dysa::SetParamFromString(all_on.params, assignment);
      std::vector<std::pair<std::string, dysa::Scene>> configs = {{"all on", all_on}};
      dysa::Scene all_off = all_on;
      for (const Feature& f : kFeatures) {
        dysa::Scene one_off = all_on;
        if (!f.off(one_off, solver.physical)) continue;
        f.off(all_off, solver.physical);
        configs.emplace_back(f.name + " off", one_off);
      }
      configs.emplace_back("all off", all_off);
      Timing reference;
      for (const auto& [name, scene] : configs) {
        const Timing t = Measure(scene, warmup, steps, repeats);
        if (name == "all on") reference = t;
        const double speedup = reference.ms_per_step / t.ms_per_step;
        std::printf("%-6s %-18s %7zu particles  %8.3f ms/step  x%.2f",
                    std::string(solver.name).c_str(), name.c_str(), t.particles, t.ms_per_step,
                    speedup);
        if (t.iterations_per_step > 0) {
          std::printf("  (solves %.3f ms, %.1f iterations)", t.solve_ms_per_step,
                      t.iterations_per_step);
        }
        std::printf("  passes: %s\n", Join(t.passes).c_str());
        csv << solver.name << ',' << name << ',' << t.particles << ',' << threads << ','
            << t.ms_per_step << ',' << speedup << ',' << t.solve_ms_per_step << ','
            << t.iterations_per_step << ',' << Join(t.passes) << '\n';
        if (name == "all off") {
          const double faster = 1 - t.ms_per_step / reference.ms_per_step;
          std::printf("%-6s all off is %.0f%% faster than all on (target >= 20%%: %s)\n",
                      std::string(solver.name).c_str(), 100 * faster,
                      faster >= 0.2 ? "met" : "missed");
          if (t.iterations_per_step > 0) {
            // The passes alone: the step less its iterative solves, whose work follows the flow.
            const double outside = 1 - (t.ms_per_step - t.solve_ms_per_step) /
                                           (reference.ms_per_step - reference.solve_ms_per_step);
            std::printf(
                "%-6s outside the pressure solves all off is %.0f%% faster; the solves "
                "took %.1f iterations per step against %.1f with all on\n",
                std::string(solver.name).c_str(), 100 * outside, t.iterations_per_step,
                reference.iterations_per_step);
          }
        }
      }
    }
    // Adaptive against fixed steps: the dam break (wcsph and dfsph at a / 15) with the CFL step,
    // against the fixed step a run would need to be safe throughout, the smallest the CFL
    // condition asked for anywhere in the run.
    std::ofstream steps_csv(std::filesystem::path(out_dir) / "adaptive_steps.csv");
    steps_csv
        << "solver,case,particles,end_time_s,adaptive_steps,smallest_dt_s,fixed_steps,ratio\n";
    for (const char* solver : {"wcsph", "dfsph"}) {
      dysa::Scene scene =
          dysa::SlabAtSpacing(dysa::LoadScene("dam_break_martin_moyce"), 0.05715 / 15);
      scene.solver = solver;
      dysa::Simulation sim(scene);
      double smallest = 1e30;
      while (sim.time() < scene.end_time && sim.alarm().empty()) {
        sim.Step(scene.end_time);
        // The last step is cut to land on end_time: not a step the CFL condition chose.
        if (sim.time() < scene.end_time) smallest = std::min(smallest, sim.last_dt());
      }
      const double fixed = std::ceil(scene.end_time / smallest);
      const double ratio = fixed / double(sim.step());
      std::printf(
          "%-6s dam break a/15 %zu particles to t = %.3f s: %llu adaptive steps; the "
          "smallest was %.3g s, so a fixed step needs %.0f (x%.2f)\n",
          solver, sim.particle_count(), scene.end_time, (unsigned long long)sim.step(), smallest,
          fixed, ratio);
      steps_csv << solver << ",dam_break," << sim.particle_count() << ',' << scene.end_time << ','
                << sim.step() << ',' << smallest << ',' << fixed << ',' << ratio << '\n';
    }
    std::printf("wrote %s/pass_skipping.csv and adaptive_steps.csv\n", out_dir.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pass_skipping_bench: error: %s\n", e.what());
    return 1;
  }
}
