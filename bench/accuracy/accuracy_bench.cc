// Run time against error: the validation cases (hydrostatic tank, Martin & Moyce dam break,
// Poiseuille flow) for every physical solver, particle spacing and time-step or tolerance
// setting. Writes
// bench/results/accuracy.csv; bench/accuracy/plot_accuracy.py draws error against wall time with
// the Pareto front (bench/README.md, "Run time against error").
//
//   build/release/bench/accuracy_bench [--threads 2]
//                                      [--case all|hydrostatic|dam_break|poiseuille]
//                                      [--solvers wcsph,dfsph] [--quick | --fine]
//   build/release/bench/accuracy_bench --case spheric_test2 [--quick | --fine] [--device cuda]
//                                      [--spacings 0.02,0.01] [--end 1.0] [--step-series]
//
// SPHERIC Test 2, a 3D case of minutes per run, is not part of `all`: `--case spheric_test2`
// runs it alone (wcsph, to 1 s by default: the arrival, the peak and the H4 error all lie in the
// first second; --end changes it) into accuracy_spheric_test2.csv, and writes each run's filtered
// sensors and gauges every millisecond into spheric_test2_series_SPACING.csv for
// plot_accuracy.py. --spacings replaces the default spacings; --step-series also writes every
// step's raw probe values (P1-P8 in Pa, H1-H4 in m, as the run records them) into
// spheric_test2_steps_SPACING.csv and the box force every ~0.1 ms into
// spheric_test2_force_SPACING.csv, which bench/peer_compare.py reads beside DualSPHysics's gauges.
#include <omp.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <stdexcept>
#include <string>
#include <vector>

#include "dysa/core/solver.h"
#include "dysa/validation/validation.h"
#include "dysa/validation/validation_impact.h"

namespace {

// One point of the sweep: a case at a spacing with parameter overrides.
struct Setting {
  std::string label;              // e.g. "cfl_factor=0.25"
  std::vector<std::string> sets;  // NAME=VALUE
};

// What is swept per solver besides the spacing: the CFL factor of the adaptive step for both,
// and DFSPH's density error tolerance and warm start (its iterations trade time for
// incompressibility).
std::vector<Setting> SettingsFor(const std::string& solver, bool quick) {
  std::vector<Setting> out;
  // DFSPH steps with at most kIncompressibleMaxCfl = 0.3 (cfl_time_step.h).
  const std::vector<double> cfl = quick               ? std::vector<double>{0.25}
                                  : solver == "dfsph" ? std::vector<double>{0.2, 0.3}
                                                      : std::vector<double>{0.25, 0.4};
  for (double c : cfl) {
    const std::string s = "cfl_factor=" + std::to_string(c).substr(0, 4);
    out.push_back({s, {s}});
  }
  if (solver == "dfsph" && !quick) {
    const std::string s = "density_tolerance=0.001";  // ten times the default 0.0001
    out.push_back({s, {"cfl_factor=0.3", s}});
    const std::string w = "warm_start=0.5";  // more of the previous step's pressure than 0.2
    out.push_back({w, {"cfl_factor=0.3", w}});
  }
  return out;
}

struct Point {
  std::string case_name, solver, setting;
  double spacing = 0;
  size_t particles = 0;
  uint64_t steps = 0;
  double wall_s = 0;
  double error = 0;  // the case's headline error (fraction)
  // hydrostatic: max pressure error; dam break: max front error; Poiseuille: the error at the
  // last (steady) time
  double error_other = 0;
  double density_error_mean = 0;
};

// A number > 0 (CLI11's PositiveNumber prints the whole double range in its message).
const CLI::Validator kPositive(
    [](std::string& text) -> std::string {
      char* end = nullptr;
      const double v = std::strtod(text.c_str(), &end);
      if (end == text.c_str() || *end != '\0' || !(v > 0) || !std::isfinite(v)) {
        return "'" + text + "' is not a positive number";
      }
      return "";
    },
    "POSITIVE");

double Seconds(std::chrono::steady_clock::duration d) {
  return std::chrono::duration<double>(d).count();
}

struct SphericOptions {
  bool quick = false, fine = false;
  std::vector<double> spacings;   // m; empty: the defaults below
  double end = 1.0;               // s, simulated
  bool step_series = false;       // also write every step's raw probes
  std::vector<std::string> sets;  // NAME=VALUE overrides (the kernel, c0, ...)
  std::string solver;             // "": the scene's (wcsph)
  dysa::Device device;
};

// The raw probe values after every step (SphericTest2Result::times, pressure, height).
void WriteStepSeries(const std::filesystem::path& path, const dysa::SphericTest2Result& r) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot write " + path.string());
  out << "t_s,P1_pa,P2_pa,P3_pa,P4_pa,P5_pa,P6_pa,P7_pa,P8_pa,H1_m,H2_m,H3_m,H4_m\n";
  out << std::setprecision(9);
  for (size_t k = 0; k < r.times.size(); ++k) {
    out << r.times[k];
    for (const auto& p : r.pressure) out << ',' << p[k];
    for (const auto& h : r.height) out << ',' << h[k];
    out << '\n';
  }
  if (!out) throw std::runtime_error("error writing " + path.string());
}

// The box force's readings (SphericTest2Result::force_times, force_x), every ~0.1 ms.
void WriteForceSeries(const std::filesystem::path& path, const dysa::SphericTest2Result& r) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot write " + path.string());
  out << "t_s,Fx_n\n" << std::setprecision(9);
  for (size_t k = 0; k < r.force_times.size(); ++k)
    out << r.force_times[k] << ',' << r.force_x[k] << '\n';
  if (!out) throw std::runtime_error("error writing " + path.string());
}

// SPHERIC Test 2 at spacings that are whole fractions of the water's 0.55 m depth (7, 9 and 11
// layers; --fine adds the scene's 0.025 m, 22 layers), so that the reservoir starts at the
// experiment's depth; or at --spacings.
int RunSpheric(const std::filesystem::path& out_dir, const SphericOptions& o) {
  std::vector<double> spacings = {0.55 / 7, 0.55 / 9, 0.55 / 11};
  if (o.quick) spacings = {0.55 / 7, 0.55 / 9};
  if (o.fine) spacings.push_back(0.025);
  if (!o.spacings.empty()) spacings = o.spacings;
  const double end = o.end;  // s, simulated
  std::ofstream csv(out_dir / "accuracy_spheric_test2.csv");
  csv << "solver,spacing_m,particles,steps,particle_steps,wall_s,end_s,p1_arrival_s,"
         "p1_arrival_error_s,p1_peak_pa,p1_peak_error,p1_impact_mean_pa,h4_error_1s,h1_error,"
         "h2_error,h3_error,h4_error,p1_peak_5ms_pa,p2_arrival_s,p2_peak_pa,p2_peak_error,"
         "force_peak_n,force_peak_time_s\n";
  std::printf("%-8s %9s %9s %7s %8s %10s %10s %9s %9s\n", "spacing", "particles", "steps", "wall s",
              "arrival", "arrival-", "peak kPa", "peak err", "H4 err");
  for (double spacing : spacings) {
    dysa::ValidationOptions options;
    options.spacing = spacing;
    options.device = o.device;
    options.sets = o.sets;
    options.solver = o.solver;
    const auto start = std::chrono::steady_clock::now();
    const dysa::SphericTest2Result r = dysa::RunSphericTest2(options, end);
    const double wall = Seconds(std::chrono::steady_clock::now() - start);
    const double arrival = r.p1_arrival.value_or(std::nan(""));
    const double peak_error = r.p1_peak / dysa::kP1PeakMeasured - 1;
    std::printf("%-8.4f %9zu %9llu %7.1f %8.4f %+9.1fms %10.2f %+8.0f%% %8.2f%%\n", spacing,
                r.run.particles, (unsigned long long)r.run.steps, wall, arrival,
                1000 * (arrival - dysa::kP1ArrivalMeasured), r.p1_peak / 1000, 100 * peak_error,
                100 * r.h4_error_first_second);
    std::fflush(stdout);
    csv << r.run.solver << ',' << spacing << ',' << r.run.particles << ',' << r.run.steps << ','
        << double(r.run.particles) * double(r.run.steps) << ',' << wall << ',' << r.run.time << ','
        << arrival << ',' << arrival - dysa::kP1ArrivalMeasured << ',' << r.p1_peak << ','
        << peak_error << ',' << r.p1_impact_mean << ',' << r.h4_error_first_second;
    for (double e : r.height_error) csv << ',' << e;
    csv << ',' << r.p1_peak_5ms << ',' << r.p2_arrival.value_or(std::nan("")) << ',' << r.p2_peak
        << ',' << r.p2_peak / dysa::kP2PeakMeasured - 1 << ',' << r.force_peak << ','
        << r.force_peak_time;
    csv << '\n';
    csv.flush();
    char name[64];
    if (o.step_series) {
      std::snprintf(name, sizeof name, "spheric_test2_steps_%.4f.csv", spacing);
      WriteStepSeries(out_dir / name, r);
      std::snprintf(name, sizeof name, "spheric_test2_force_%.4f.csv", spacing);
      WriteForceSeries(out_dir / name, r);
    }
    // Every millisecond: the last step at or before it.
    std::snprintf(name, sizeof name, "spheric_test2_series_%.4f.csv", spacing);
    std::ofstream series(out_dir / name);
    series << "t_s,P1_pa,P2_pa,P3_pa,P4_pa,P5_pa,P6_pa,P7_pa,P8_pa,H1_m,H2_m,H3_m,H4_m\n";
    size_t k = 0;
    for (int ms = 0; ms <= int(end * 1000 + 0.5); ++ms) {
      const double t = 0.001 * ms;
      while (k + 1 < r.times.size() && r.times[k + 1] <= t + 1e-12) ++k;
      series << t;
      for (const auto& p : r.pressure_filtered) series << ',' << p[k];
      for (const auto& h : r.height) series << ',' << h[k];
      series << '\n';
    }
  }
  std::printf("wrote %s\n", (out_dir / "accuracy_spheric_test2.csv").c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Run time against error of the physical solvers on the validation cases"};
  int threads = 2;
  std::string which = "all";
  std::vector<std::string> solvers;
  bool quick = false, fine = false;
  std::string out_dir = "bench/results";
  app.add_option("--threads", threads, "OpenMP threads")->check(CLI::Range(1, 1024));
  app.add_option("--case", which,
                 "all, hydrostatic, dam_break, poiseuille, or spheric_test2 (not in all)")
      ->check(CLI::IsMember({"all", "hydrostatic", "dam_break", "poiseuille", "spheric_test2"}));
  app.add_option("--solvers", solvers, "Solvers (default: every physical one)")->delimiter(',');
  app.add_flag("--quick", quick, "Two coarse spacings and one setting (a smoke run)");
  app.add_flag("--fine", fine, "Also the validation scenes' own spacings (minutes per run)");
  app.add_option("--out", out_dir, "Directory for accuracy.csv")->capture_default_str();
  std::string device = "cpu";
  app.add_option("--device", device, "cpu or cuda[:N] (spheric_test2 only)")->capture_default_str();
  SphericOptions spheric;
  auto* spacings_opt =
      app.add_option("--spacings", spheric.spacings,
                     "Comma list of particle spacings in m (spheric_test2 only; replaces the "
                     "default ones)")
          ->delimiter(',')
          ->check(kPositive);
  auto* end_opt = app.add_option("--end", spheric.end, "Simulated end time in s (spheric_test2)")
                      ->check(kPositive)
                      ->capture_default_str();
  auto* steps_opt = app.add_flag("--step-series", spheric.step_series,
                                 "Also write spheric_test2_steps_SPACING.csv: every step's raw "
                                 "P1-P8 and H1-H4 (spheric_test2)");
  auto* set_opt = app.add_option("--set", spheric.sets,
                                 "Override a parameter, NAME=VALUE (repeatable; spheric_test2; "
                                 "e.g. kernel=1, smoothing_length_ratio=1.732)");
  CLI11_PARSE(app, argc, argv);
  omp_set_num_threads(threads);
  if (which != "spheric_test2") {
    for (const CLI::Option* opt : {spacings_opt, end_opt, steps_opt, set_opt}) {
      if (opt->count() > 0) {
        std::fprintf(stderr, "accuracy_bench: error: %s applies to --case spheric_test2 only\n",
                     opt->get_name().c_str());
        return 2;
      }
    }
  }
  if (which == "spheric_test2") {
    try {
      std::filesystem::create_directories(out_dir);
      spheric.quick = quick;
      spheric.fine = fine;
      spheric.device = dysa::ParseDevice(device);
      if (solvers.size() > 1) {
        std::fprintf(stderr, "accuracy_bench: error: --solvers: spheric_test2 runs one solver\n");
        return 2;
      }
      if (!solvers.empty()) spheric.solver = solvers.front();
      return RunSpheric(out_dir, spheric);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "accuracy_bench: error: %s\n", e.what());
      return 1;
    }
  }

  if (solvers.empty()) {
    for (const dysa::SolverInfo& info : dysa::SolverRegistry()) {
      if (info.physical) solvers.emplace_back(info.name);
    }
  }
  // Spacings in m: the hydrostatic tank is 0.9 m deep (default 0.02), the dam break's column
  // a = 0.05715 m wide (default a / 30), 2a tall.
  const double a = 0.05715;
  // Tank spacings divide both its 2 m width and 0.9 m depth (a fractional layer would leave the
  // fluid shallower than the depth the reference pressure is computed for).
  std::vector<double> tank = {0.1, 0.05, 0.025};
  std::vector<double> dam = {a / 8, a / 10, a / 12};
  // The Poiseuille channel is L = 1 cm wide (default L / 20).
  std::vector<double> channel = {0.001, 0.0005, 0.00025};
  if (quick) tank.pop_back(), dam.pop_back(), channel.pop_back();
  if (fine) tank.push_back(0.02), dam.push_back(a / 30);  // the scenes' own resolutions
  const char* kCases[] = {"hydrostatic", "dam_break", "poiseuille"};
  try {
    std::filesystem::create_directories(out_dir);
    std::ofstream csv(std::filesystem::path(out_dir) / "accuracy.csv");
    csv << "case,solver,setting,spacing_m,particles,steps,particle_steps,wall_s,error,"
           "error_max,density_error_mean\n";
    std::printf("%-12s %-6s %-24s %10s %9s %8s %9s %10s %10s\n", "case", "solver", "setting",
                "spacing m", "particles", "steps", "wall s", "error", "max error");
    for (const std::string& solver : solvers) {
      for (const Setting& setting : SettingsFor(solver, quick)) {
        for (const std::string case_name : kCases) {
          if (which != "all" && which != case_name) continue;
          const bool hydrostatic = case_name == "hydrostatic";
          const bool dam_break = case_name == "dam_break";
          for (double spacing : hydrostatic ? tank : dam_break ? dam : channel) {
            dysa::ValidationOptions options;
            options.solver = solver;
            options.spacing = spacing;
            options.sets = setting.sets;
            Point p;
            p.case_name = case_name;
            p.solver = solver;
            p.setting = setting.label;
            p.spacing = spacing;
            const auto start = std::chrono::steady_clock::now();
            dysa::ValidationRun run;
            if (hydrostatic) {
              const dysa::HydrostaticResult r = dysa::RunHydrostaticTank(options);
              run = r.run;
              p.error = r.pressure_error_mean;
              p.error_other = r.pressure_error_max;
              p.density_error_mean = r.density_error_mean;
            } else if (dam_break) {
              const dysa::DamBreakResult r = dysa::RunDamBreak(options);
              run = r.run;
              p.error = r.rms_error;
              p.error_other = r.max_error;
            } else {
              const dysa::PoiseuilleResult r = dysa::RunPoiseuille(options);
              run = r.run;
              p.error = r.error_max;
              p.error_other = r.profiles.back().error_max;
            }
            p.wall_s = Seconds(std::chrono::steady_clock::now() - start);
            p.particles = run.particles;
            p.steps = run.steps;
            std::printf("%-12s %-6s %-24s %10.5f %9zu %8llu %9.2f %10.4f %10.4f\n",
                        p.case_name.c_str(), solver.c_str(), p.setting.c_str(), spacing,
                        p.particles, (unsigned long long)p.steps, p.wall_s, p.error, p.error_other);
            std::fflush(stdout);
            csv << p.case_name << ',' << solver << ',' << p.setting << ',' << spacing << ','
                << p.particles << ',' << p.steps << ',' << double(p.particles) * double(p.steps)
                << ',' << p.wall_s << ',' << p.error << ',' << p.error_other << ','
                << p.density_error_mean << '\n';
            csv.flush();
          }
        }
      }
    }
    std::printf("wrote %s/accuracy.csv\n", out_dir.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "accuracy_bench: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
