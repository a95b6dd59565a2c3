#include "validate_command.h"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <optional>
#include <ostream>
#include <sstream>
#include <string_view>

#include "dysa/core/text.h"
#include "dysa/validation/validation.h"
#include "validate_impact.h"

namespace dysa {
namespace {

// The quick resolutions of tests/validation/validation_test.cc.
constexpr double kQuickTankSpacing = 0.05;
constexpr double kQuickDamSpacing = 0.05715 / 15;
constexpr double kQuickChannelSpacing = 0.001;  // 10 particles across the 1 cm channel
// The residual height's bound at the quick resolution, as validation_test asserts it.
constexpr double kQuickHeightRmsBound = 0.1;

struct Row {
  std::string measure;
  double value;         // a fraction, printed as %
  double target;        // value must not exceed it
  bool percent = true;  // a fraction, printed as %; else a count
};

class Table {
 public:
  explicit Table(std::ostream& out) : out_(out) {
    out_ << std::left << std::setw(20) << "case" << std::setw(34) << "measure" << std::right
         << std::setw(10) << "value" << std::setw(10) << "target"
         << "  status\n";
  }
  void Add(const std::string& name, const Row& row) {
    const bool ok = row.value <= row.target;
    all_ok_ &= ok;
    out_ << std::left << std::setw(20) << name << std::setw(34) << row.measure << std::right
         << std::fixed << std::setprecision(row.percent ? 2 : 0) << std::setw(9)
         << (row.percent ? 100 : 1) * row.value << (row.percent ? "%" : " ") << std::setw(9)
         << (row.percent ? 100 : 1) * row.target << (row.percent ? "%" : " ")
         << (ok ? "  ok" : "  MISSED") << "\n";
    out_.unsetf(std::ios::floatfield);
  }
  bool all_ok() const { return all_ok_; }

 private:
  std::ostream& out_;
  bool all_ok_ = true;
};

std::string RunText(const ValidationRun& run, double seconds) {
  std::ostringstream s;
  s << "  " << run.solver << ", spacing " << run.spacing << " m, " << run.particles
    << " fluid particles, " << run.steps << " steps to t = " << run.time << " s, "
    << std::setprecision(3) << seconds << " s wall\n";
  return s.str();
}

std::string TankDiagnosticsText(const HydrostaticResult& h) {
  // rho0 g, from the reference line rho0 g (H - y) at the first and last sample.
  const auto& first = h.profile.front();
  const auto& last = h.profile.back();
  const double rho_g = (first.reference - last.reference) / (last.y - first.y);
  std::ostringstream s;
  s << "    bottom layer at " << std::fixed << std::setprecision(3) << h.bottom_layer_height
    << " d above the floor (0.5 d: held by the wall's pressure)\n"
    << "    centre of mass sank " << h.settling << " d over the run (compression alone: "
    << "a few hundredths)\n"
    << "    pressure gradient " << std::setprecision(1) << h.pressure_gradient << " Pa/m ("
    << std::setprecision(3) << h.pressure_gradient / rho_g << " rho0 g)\n";
  // Where the largest error lies tells a wall's effect (near the floor) from the surface's.
  const auto worst = std::max_element(h.profile.begin(), h.profile.end(), [](auto& a, auto& b) {
    return std::abs(a.pressure - a.reference) < std::abs(b.pressure - b.reference);
  });
  const double d = h.profile.size() > 1 ? h.profile[1].y - first.y : first.y;
  s << "    largest pressure error at y = " << std::setprecision(3) << worst->y << " m ("
    << std::setprecision(1) << worst->y / d << " d above the floor, " << std::showpos
    << 100 * (worst->pressure - worst->reference) / (rho_g * h.depth) << std::noshowpos
    << "% of rho0 g H)\n";
  // The errors' own uncertainty: runs that differ by less than about twice it are not
  // distinguishable by the window's average.
  s << "    standard error of the averaged pressure: up to " << std::setprecision(2)
    << 100 * h.pressure_error_uncertainty << "% of rho0 g H (" << kHydrostaticBatches
    << " batch means of the " << kHydrostaticAveragingTime << " s window)\n";
  return s.str();
}

// Where the dam break's error lies (DiagnoseFront): the surge's speed, and the error left once
// the experiment is taken to have released its column a constant time later.
std::string FrontDiagnosticsText(const DamBreakResult& d) {
  const FrontDiagnostics& f = d.diagnostics;
  std::ostringstream s;
  s << std::fixed << std::setprecision(2) << "    front speed dZ/dT from T = " << kSurgeFrom
    << std::setprecision(3) << ": " << f.front_speed << " (experiment " << f.front_speed_ref
    << ")\n"
    << "    with the experiment's release taken " << std::setprecision(1)
    << 1000 * f.release_delay * d.time_unit << " ms later (T = " << std::setprecision(3)
    << f.release_delay << ", the best fit): RMS error " << std::setprecision(1)
    << 100 * f.delayed.rms << "%, max " << 100 * f.delayed.max << "%\n"
    << "    with Lethe's time correction (T = " << std::setprecision(3) << kPublishedReleaseDelay
    << ", not fitted here): RMS error " << std::setprecision(1) << 100 * f.published.rms
    << "%, max " << 100 * f.published.max << "%\n";
  return s.str();
}

// The channel's error at each of Morris et al.'s times, and its steady centre speed.
std::string PoiseuilleText(const PoiseuilleResult& c) {
  std::ostringstream s;
  s << std::fixed << "    u_max = F L^2 / (8 nu) = " << std::setprecision(3) << 1000 * c.peak_speed
    << " mm/s; error / u_max at t =";
  for (const PoiseuilleResult::Profile& p : c.profiles) {
    s << " " << std::setprecision(4) << p.t << " s: " << std::setprecision(2) << 100 * p.error_max
      << "%" << (&p == &c.profiles.back() ? "\n" : ",");
  }
  const PoiseuilleResult::Profile& last = c.profiles.back();
  const size_t mid = last.speed.size() / 2;
  if (!last.speed.empty()) {
    s << "    centre column at t = " << std::setprecision(4) << last.t
      << " s: " << std::setprecision(4) << last.speed[mid] / c.peak_speed << " u_max (analytic "
      << last.reference[mid] / c.peak_speed << ")\n";
  }
  return s.str();
}

}  // namespace

const std::vector<std::string>& ValidationCaseNames() {
  static const std::vector<std::string> names = {"hydrostatic_tank", "dam_break", "poiseuille_flow",
                                                 "spheric_test2"};
  return names;
}

int RunValidate(const ValidateOptions& options, std::ostream& out) {
  for (const std::string& name : options.cases) {
    const auto& known = ValidationCaseNames();
    if (std::find(known.begin(), known.end(), name) == known.end()) {
      std::string list;
      for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
      throw ConfigError("--case", "no validation case " + SafeText(name) + "; the cases: " + list);
    }
  }
  const auto selected = [&](std::string_view name) {
    return options.cases.empty() ||
           std::find(options.cases.begin(), options.cases.end(), name) != options.cases.end();
  };
  if (options.threads > 0) omp_set_num_threads(options.threads);
  using Clock = std::chrono::steady_clock;
  const auto seconds_since = [](Clock::time_point start) {
    return std::chrono::duration<double>(Clock::now() - start).count();
  };
  ValidationOptions base;
  base.solver = options.solver;
  base.sets = options.sets;
  base.slab_layers = options.slab_layers;
  base.device = options.device;
  // Fails here, naming what is missing, rather than after the first case's set-up.
  const std::string device = QueryDevice(options.device).Describe(options.device);
  // Targets: at the scenes' resolution the project's (hydrostatic pressure within 1% of
  // rho0 g H, dam-break front RMS within 5%); --quick, the bounds the CI test asserts.
  const bool quick = options.quick;
  out << (quick ? "quick resolutions (the CI bounds)" : "scene resolutions (the project targets)")
      << (options.device.is_cuda() ? ", on " + device : "") << "\n";

  std::optional<HydrostaticResult> h;
  std::string tank_run;
  // dfsph on the tank too (unless another solver was asked for): incompressible to 0.1%.
  std::optional<HydrostaticResult> incompressible;
  std::string incompressible_run;
  if (selected("hydrostatic_tank")) {
    ValidationOptions tank = base;
    if (quick) tank.spacing = kQuickTankSpacing;
    auto start = Clock::now();
    h = RunHydrostaticTank(tank);
    tank_run = RunText(h->run, seconds_since(start)) + TankDiagnosticsText(*h);
    if (options.solver.empty()) {
      ValidationOptions tank_dfsph = tank;
      tank_dfsph.solver = "dfsph";
      start = Clock::now();
      incompressible = RunHydrostaticTank(tank_dfsph);
      incompressible_run =
          RunText(incompressible->run, seconds_since(start)) + TankDiagnosticsText(*incompressible);
    }
  }

  std::optional<DamBreakResult> d, gated;
  std::string dam_run, gated_run;
  if (selected("dam_break")) {
    ValidationOptions dam = base;
    if (quick) dam.spacing = kQuickDamSpacing;
    auto start = Clock::now();
    d = RunDamBreak(dam);
    dam_run = RunText(d->run, seconds_since(start)) + FrontDiagnosticsText(*d);
    // The same with the release modelled by a lifted gate (dam_break_martin_moyce_gate).
    start = Clock::now();
    gated = RunGatedDamBreak(dam);
    gated_run = RunText(gated->run, seconds_since(start)) + FrontDiagnosticsText(*gated);
  }

  // Poiseuille flow: the viscous term and no-slip walls, with the scene's solver and (unless
  // one solver was asked for) dfsph too.
  std::vector<PoiseuilleResult> channels;
  std::string channel_runs;
  if (selected("poiseuille_flow")) {
    ValidationOptions channel = base;
    if (quick) channel.spacing = kQuickChannelSpacing;
    std::vector<std::string> channel_solvers = {options.solver};
    if (options.solver.empty()) channel_solvers.push_back("dfsph");
    for (const std::string& solver : channel_solvers) {
      channel.solver = solver;
      const auto start = Clock::now();
      channels.push_back(RunPoiseuille(channel));
      channel_runs += "poiseuille_flow:" + RunText(channels.back().run, seconds_since(start)) +
                      PoiseuilleText(channels.back());
    }
  }

  // SPHERIC Test 2: a 3D impact case (its slab_layers do not apply).
  std::optional<SphericTest2Result> spheric;
  std::string spheric_run;
  if (selected("spheric_test2")) {
    ValidationOptions impact = base;
    if (quick) impact.spacing = kQuickSphericSpacing;
    const auto start = Clock::now();
    spheric = RunSphericTest2(impact);
    spheric_run = RunText(spheric->run, seconds_since(start)) + SphericDiagnosticsText(*spheric);
  }

  out << "\n";
  Table table(out);
  if (h) {
    table.Add("hydrostatic_tank", {"pressure error max / rho0 g H", h->pressure_error_max, 0.01});
    table.Add("hydrostatic_tank",
              {"pressure error mean / rho0 g H", h->pressure_error_mean, quick ? 0.005 : 0.01});
    table.Add("hydrostatic_tank", {"density deviation mean", h->density_error_mean, 0.01});
    table.Add("hydrostatic_tank", {"density deviation max", h->density_error_max, 0.01});
  }
  if (d) {
    table.Add("dam_break", {"front Z RMS error (Martin&Moyce)", d->rms_error, quick ? 0.2 : 0.05});
    table.Add("dam_break", {"front Z max error", d->max_error, quick ? 0.3 : 0.1});
    // The gate's jet under its edge leads the front further (docs/validation.md): the quick
    // bounds catch a regression, the scene-resolution target is the 5%.
    table.Add("dam_break (gate)",
              {"front Z RMS error (Martin&Moyce)", gated->rms_error, quick ? 0.3 : 0.05});
    table.Add("dam_break (gate)", {"front Z max error", gated->max_error, quick ? 0.4 : 0.1});
    table.Add("dam_break", {"residual height RMS error (M&M)", d->height_rms_error,
                            quick ? kQuickHeightRmsBound : 0.05});
  }
  if (incompressible) {
    table.Add("hydrostatic (dfsph)",
              {"density deviation mean", incompressible->density_error_mean, 0.001});
    table.Add("hydrostatic (dfsph)",
              {"pressure error max / rho0 g H", incompressible->pressure_error_max, 0.01});
    table.Add("hydrostatic (dfsph)", {"pressure error mean / rho0 g H",
                                      incompressible->pressure_error_mean, quick ? 0.005 : 0.01});
    table.Add("hydrostatic (dfsph)",
              {"solves stopped at the cap", double(incompressible->capped_solves), 0, false});
  }
  for (const PoiseuilleResult& c : channels) {
    table.Add("poiseuille (" + c.run.solver + ")",
              {"velocity error max / u_max", c.error_max, quick ? 0.015 : 0.01});
  }
  if (spheric) {
    // Quick: the arrival within 40 ms, as tests/validation/spheric_test2_test.cc asserts, and H4
    // within 8% over the first second (that test runs to 0.535 s only; 6.2% measured to 1 s); no
    // bound on the peak, which particle-scale impacts dominate at that resolution
    // (SphericDiagnosticsText prints it).
    const double arrival_error =
        spheric->p1_arrival ? 1000 * std::abs(*spheric->p1_arrival - kP1ArrivalMeasured) : 1e9;
    table.Add("spheric_test2", {"|P1 arrival - 0.393 s|, ms", arrival_error,
                                quick ? 40 : 1000 * kP1ArrivalTarget, false});
    if (!quick) {
      table.Add("spheric_test2", {"P1 1 ms peak error (11.24 kPa)",
                                  std::abs(spheric->p1_peak / kP1PeakMeasured - 1), kPeakTarget});
      table.Add("spheric_test2", {"P2 1 ms peak error (8.13 kPa)",
                                  std::abs(spheric->p2_peak / kP2PeakMeasured - 1), kPeakTarget});
    }
    table.Add("spheric_test2", {"H4 RMS error, t <= 1 s (MARIN)", spheric->h4_error_first_second,
                                quick ? 0.08 : kH4FirstSecondTarget});
  }
  out << "\n";
  if (h) out << "hydrostatic_tank:" << tank_run;
  if (d) out << "dam_break_martin_moyce:" << dam_run << "dam_break_martin_moyce_gate:" << gated_run;
  if (incompressible) out << "hydrostatic_tank (dfsph):" << incompressible_run;
  out << channel_runs;
  if (spheric) out << "spheric_test2:" << spheric_run;
  if (d) {
    out << "\ndam break front (T = t sqrt(2 g / a), Z = x / a):\n    T      Z  Z_ref\n";
    for (const DamBreakResult::Row& row : d->rows) {
      out << std::fixed << std::setprecision(2) << std::setw(5) << row.T << std::setprecision(3)
          << std::setw(7) << row.Z << std::setw(7) << row.Z_ref << "\n";
    }
    out << "\ndam break front with the gate (t = 0: the lift starts):\n    T      Z  Z_ref\n";
    for (const DamBreakResult::Row& row : gated->rows) {
      out << std::fixed << std::setprecision(2) << std::setw(5) << row.T << std::setprecision(3)
          << std::setw(7) << row.Z << std::setw(7) << row.Z_ref << "\n";
    }
    out << "\nresidual height at the wall (tau = t sqrt(g / a), H = eta / (2 a)):\n"
        << "  tau      H  H_ref\n";
    for (const DamBreakResult::HeightRow& row : d->heights) {
      out << std::fixed << std::setprecision(2) << std::setw(5) << row.tau << std::setprecision(3)
          << std::setw(7) << row.H << std::setw(7) << row.H_ref << "\n";
    }
    out << "    RMS error " << std::setprecision(1) << 100 * d->height_rms_error << "%, max "
        << 100 * d->height_max_error << "%\n";
  }
  out.unsetf(std::ios::floatfield);
  if (spheric) out << SphericSeriesText(*spheric);
  out << (table.all_ok() ? "validate: all targets met\n" : "validate: targets MISSED\n");
  return table.all_ok() ? 0 : 1;
}

}  // namespace dysa
