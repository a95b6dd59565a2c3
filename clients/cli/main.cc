// dysa: the DySAQUASIMs command line. Argument parsing and wiring only.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <iostream>

#include "dysa/core/params.h"
#include "dysa/core/scene.h"
#include "dysa/core/solver.h"
#include "run_command.h"

namespace {

std::string ParameterHelp() {
  std::string text = "Parameters for --set (name, range, default):\n";
  for (const dysa::ParamDecl& p : dysa::ParamTable()) {
    std::ostringstream line;
    line << "  " << p.name << "  " << p.RangeText() << ", default " << p.DefaultValue()
         << (p.needs_reset ? ", re-spawns the fluid" : "") << "\n      " << p.description << "\n";
    text += line.str();
  }
  text += "Built-in scenes:";
  for (const std::string& name : dysa::BuiltinSceneNames()) text += " " + name;
  text += "\nSolvers:";
  for (const dysa::SolverInfo& s : dysa::SolverRegistry()) text += " " + std::string(s.name);
  return text + "\n";
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"dysa: DySAQUASIMs fluid simulation command line"};
  app.require_subcommand(1);

  dysa::RunOptions run;
  double end_time = 0;
  uint64_t steps = 0;
  CLI::App* run_cmd = app.add_subcommand(
      "run", "Simulate a scene offline (no server): progress, per-pass timings, probes.csv, VTK");
  run_cmd->add_option("scene", run.scene, "Built-in scene name or path to a scene JSON file")
      ->required();
  run_cmd->add_option("--set", run.sets, "Override a parameter, NAME=VALUE (repeatable)");
  auto* end_opt = run_cmd
                      ->add_option("--end-time", end_time,
                                   "Simulated seconds to run (default: the scene's end_time)")
                      ->check(CLI::Range(1e-9, 1e6));
  auto* steps_opt =
      run_cmd->add_option("--steps", steps, "Number of solver steps to run instead of --end-time")
          ->check(CLI::Range(uint64_t{1}, uint64_t{1} << 40));
  end_opt->excludes(steps_opt);
  run_cmd->add_option("--threads", run.threads, "OpenMP threads (default: all cores)")
      ->check(CLI::Range(1, 1024));
  run_cmd->add_option("--out", run.out_dir, "Output directory for probes.csv and frames")
      ->capture_default_str();
  run_cmd
      ->add_option("--vtk-every", run.vtk_every,
                   "Write a ParaView frame (OUT/frames/*.vtp, OUT/frames.pvd) every K frames")
      ->check(CLI::Range(1, 1 << 30));
  run_cmd->footer(ParameterHelp());

  CLI11_PARSE(app, argc, argv);

  if (run_cmd->parsed()) {
    if (*end_opt) run.end_time = end_time;
    if (*steps_opt) run.steps = steps;
    run.progress = isatty(STDERR_FILENO) != 0;
    try {
      dysa::RunOffline(run, std::cout, std::cerr);
    } catch (const std::exception& e) {
      std::cerr << "dysa run: error: " << e.what() << "\n";
      return 1;
    }
  }
  return 0;
}
