#include "dysa/core/params.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <utility>

#include "dysa/core/text.h"
#include "dysa/core/types.h"

namespace dysa {
namespace {

// The ParamDecl of member `member` of Params (a double or an int), named after it, read by
// the solvers `solvers` (one of the lists below).
// clang-format off
#define DYSA_PARAM(member, unit, min, max, reset, solvers, description)                \
  ParamDecl{#member, unit, description, min, max,                                      \
            std::is_same_v<decltype(Params::member), int>, reset,                      \
            [](const Params& p) { return static_cast<double>(p.member); },             \
            [](Params& p, double v) { p.member = static_cast<decltype(Params::member)>(v); }, \
            solvers}
// clang-format on

constexpr bool kReset = true;
constexpr bool kLive = false;

// Which solvers read a parameter (SolverRegistry() names; params_test checks them against the
// registry). Read from the solvers' passes, model.cc (dt, particle mass, kernel support),
// simulation.cc (steps per frame), scene.cc and spawn.cc (fluid blocks) and cfl_time_step.cc.
constexpr std::span<const std::string_view> kAll;  // every solver
constexpr std::string_view kSeed[] = {"seed"};
constexpr std::string_view kPhysical[] = {"wcsph", "dfsph"};
constexpr std::string_view kWcsph[] = {"wcsph"};  // dfsph's step has no speed of sound
constexpr std::string_view kDfsph[] = {"dfsph"};

const std::array kParamTable = {
    DYSA_PARAM(time_scale, "", 0.01, 10.0, kLive, kAll,
               "Simulation speed: simulated seconds per second of displayed frames"),
    DYSA_PARAM(iterations_per_frame, "", 1, 100, kLive, kSeed, "Solver steps per displayed frame"),
    DYSA_PARAM(frame_rate, "Hz", 1.0, 1000.0, kLive, kAll, "Displayed frames per second"),
    DYSA_PARAM(gravity, "m/s^2", -100.0, 100.0, kLive, kAll, "Gravity along +y"),
    DYSA_PARAM(collision_damping, "", 0.0, 1.0, kLive, kSeed,
               "Fraction of the normal speed kept when a particle hits a wall or obstacle"),
    DYSA_PARAM(smoothing_radius, "m", 0.01, 10.0, kLive, kSeed,
               "Kernel support h: particles closer than h interact"),
    DYSA_PARAM(target_density, "kg/m^3", 0.001, 1e6, kLive, kSeed,
               "Rest density of the equation of state"),
    DYSA_PARAM(pressure_multiplier, "m^2/s^2", 0.0, 1e5, kLive, kSeed,
               "Stiffness k of p = (rho - rho0) k"),
    DYSA_PARAM(near_pressure_multiplier, "m^2/s^2", 0.0, 1e5, kLive, kSeed,
               "Stiffness of the near pressure p_near = rho_near k_near (0 turns it off)"),
    DYSA_PARAM(viscosity, "m^3/s", 0.0, 10.0, kLive, kSeed,
               "Viscosity strength: dv_i = mu sum_j (v_j - v_i) W_poly6 dt (0 turns it off)"),
    DYSA_PARAM(particle_mass, "kg", 1e-6, 1e6, kReset, kSeed, "Mass of every particle"),
    DYSA_PARAM(particle_quantity, "", 1, 500, kReset, kSeed,
               "Particles per axis of each fluid block that does not set its own count"),
    DYSA_PARAM(spawn_size, "m", 0.001, 1000.0, kReset, kAll,
               "Edge of each fluid block that does not set its own size"),
    DYSA_PARAM(spawn_jitter, "m", 0.0, 100.0, kReset, kSeed,
               "Random offset radius of each fluid block that does not set its own jitter"),
    DYSA_PARAM(rest_density, "kg/m^3", 1.0, 1e5, kLive, kPhysical,
               "Rest density rho0 of the fluid; particle mass rho0 d^3"),
    DYSA_PARAM(particle_spacing, "m", 1e-4, 10.0, kReset, kPhysical,
               "Lattice spacing d of the fluid; mass rho0 d^3"),
    DYSA_PARAM(kernel, "", 0, 1, kReset, kPhysical,
               "Smoothing kernel: 0 the cubic spline (Monaghan 1992), 1 Wendland C2 (Wendland "
               "1995)"),
    DYSA_PARAM(smoothing_length_ratio, "", 1.0, 2.5, kReset, kPhysical,
               "Smoothing length h over the spacing d; the kernel support is 2 h (1: 2 d, about "
               "33 neighbours; 1.732: 3.46 d, about 170)"),
    DYSA_PARAM(grid_cells_per_support, "", 1, 2, kReset, kPhysical,
               "Neighbour-grid cells per kernel support: 1 (cells of the support, 27 searched) "
               "or 2 (half-support cells, 125 searched, 42% fewer candidates)"),
    DYSA_PARAM(speed_of_sound, "m/s", 0.1, 1e5, kLive, kWcsph,
               "Speed of sound c0 of the Tait equation; stiffness B = rho0 c0^2 / 7"),
    DYSA_PARAM(kinematic_viscosity, "m^2/s", 0.0, 10.0, kLive, kPhysical,
               "Kinematic viscosity nu of the laminar viscosity (0 turns it off)"),
    DYSA_PARAM(cfl_factor, "", 0.01, 1.0, kLive, kPhysical,
               "CFL number lambda of dt <= lambda d / (c0 + v_max) (dfsph: lambda d / v_max, "
               "lambda at most 0.3)"),
    DYSA_PARAM(max_time_step, "s", 1e-7, 1.0, kLive, kPhysical, "Upper bound of the adaptive step"),
    DYSA_PARAM(density_tolerance, "", 1e-7, 0.1, kLive, kDfsph,
               "Mean density error (rho - rho0) / rho0 the density solve stops at"),
    DYSA_PARAM(divergence_tolerance, "", 1e-7, 0.1, kLive, kDfsph,
               "Mean (D rho / Dt) dt / rho0 the divergence solve stops at"),
    DYSA_PARAM(max_iterations, "", 1, 10000, kLive, kDfsph,
               "Iteration cap of each solve (reaching it is counted in the solver stats)"),
    DYSA_PARAM(warm_start, "", 0.0, 1.0, kLive, kDfsph,
               "Fraction of the previous step's pressure impulse each solve starts from "
               "(0 turns the warm start off)"),
    DYSA_PARAM(signed_corrections, "", 0, 1, kLive, kDfsph,
               "0: each solve iteration only adds pressure; 1: its corrections take either "
               "sign, the solve's total pressure stays >= 0 (a warm start's overshoot is "
               "taken back)"),
    DYSA_PARAM(density_diffusion, "", 0.0, 1.0, kLive, kWcsph,
               "delta of the density diffusion in the continuity equation (delta-SPH, Fourtakas "
               "et al. 2019; 0: none; the literature's 0.1; above 1 it over-damps the pressure)"),
    DYSA_PARAM(artificial_viscosity, "", 0.0, 1.0, kLive, kWcsph,
               "alpha of Monaghan's (1992) artificial viscosity between approaching particles, "
               "Pi_ij = -alpha c0 h (v_ij . x_ij) / ((r_ij^2 + 0.01 h^2) rho_ij), as in "
               "DualSPHysics: damps particle-scale velocity noise (0: off; the literature's "
               "0.01-0.1, DualSPHysics's 0.01 for dam breaks, 0.05 for SPHERIC Test 2)"),
    DYSA_PARAM(time_integration, "", 0, 1, kLive, kWcsph,
               "Time integration: 0 symplectic Euler (one force evaluation per step), 1 the "
               "predictor-corrector Symplectic scheme (two per step, second order; "
               "DualSPHysics's)"),
    DYSA_PARAM(particle_shifting, "", 0.0, 6.0, kLive, kWcsph,
               "Particle shifting dr = -A h |v| dt grad C (Lind et al. 2012, Skillen et al. "
               "2013): A, 0 off, 2 the usual; free-surface particles are not shifted; above 2 "
               "take time_integration 1 (a dam break at A = 4 took 26 times the steps with 0)"),
    DYSA_PARAM(carried_density_min, "", 0.5, 1.0, kLive, kWcsph,
               "The carried density's lower bound over rho0 (the upper is 1.3): 0.7 holds a splash "
               "particle's density off zero; 1 keeps a thin tongue from carrying less than rho0, "
               "so that it has pressure as soon as it is compressed"),
    DYSA_PARAM(wall_contact_range, "", 0.0, 1.0, kLive, kPhysical,
               "The wall contact's range r0 in particle spacings: no particle comes nearer than "
               "r0 / 2 to a wall or obstacle (its velocity towards it is cut, an inelastic stop; "
               "0: only at the surface itself)"),
    DYSA_PARAM(gravity_ramp_time, "s", 0.0, 100.0, kLive, kPhysical,
               "Gravity grows smoothly from 0 to its value over this time (0: at once)"),
};
#undef DYSA_PARAM

// Reads `text`, which must be a number written in full ("1e-3", not "1e-3x" or " 1e-3"), into
// `value`; returns "" or why it is not a number a double holds, quoting it.
std::string ReadNumber(std::string_view text, double& value) {
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  std::string quoted = "'";  // "'" + SafeText(...) draws a false -Wrestrict from GCC 12
  quoted += SafeText(text) + "'";
  if (text.empty() || ptr != end || (ec != std::errc() && ec != std::errc::result_out_of_range)) {
    return quoted + " is not a number";
  }
  if (ec == std::errc::result_out_of_range) {
    // from_chars leaves `value` alone; strtod tells overflow (+-HUGE_VAL) from underflow (0).
    const double rounded = std::strtod(std::string(text).c_str(), nullptr);
    return quoted + (std::isinf(rounded)
                         ? " is out of the range of a double (at most 1.8e308 in magnitude)"
                         : " is too close to 0 for a double (it would round to 0)");
  }
  if (!std::isfinite(value)) return quoted + " is not a finite number";
  return "";
}

}  // namespace

std::string ParamDecl::RangeText() const {
  // Appended piece by piece: "[" + ExactNumber(...) draws a false -Wrestrict from GCC 12.
  std::string text = "[";
  text += ExactNumber(min);
  text += ", ";
  text += ExactNumber(max);
  text += "]";
  if (!unit.empty()) text.append(" ").append(unit);
  if (integer) text += " (integer)";
  return text;
}

bool ParamDecl::ReadBy(std::string_view solver) const {
  return solvers.empty() || std::find(solvers.begin(), solvers.end(), solver) != solvers.end();
}

std::string ParamDecl::SolversText() const {
  if (solvers.empty()) return "all";
  std::string text;
  for (std::string_view s : solvers) text += (text.empty() ? "" : ", ") + std::string(s);
  return text;
}

std::span<const ParamDecl> ParamTable() { return kParamTable; }

const ParamDecl* FindParam(std::string_view name) {
  for (const ParamDecl& decl : kParamTable) {
    if (decl.name == name) return &decl;
  }
  return nullptr;
}

static const ParamDecl& RequireParam(std::string_view name) {
  const ParamDecl* decl = FindParam(name);
  if (decl == nullptr) {
    std::string known;
    for (const ParamDecl& d : kParamTable)
      known += (known.empty() ? "" : ", ") + std::string(d.name);
    throw ConfigError(SafeText(name), "unknown parameter; known parameters: " + known);
  }
  return *decl;
}

void SetParam(Params& params, std::string_view name, double value) {
  const ParamDecl& decl = RequireParam(name);
  const std::string shown = ExactNumber(value);
  if (!std::isfinite(value)) {
    throw ConfigError(std::string(name),
                      shown + " is not a finite number; allowed range " + decl.RangeText());
  }
  if (value < decl.min || value > decl.max) {
    throw ConfigError(std::string(name),
                      shown + " is outside the allowed range " + decl.RangeText());
  }
  if (decl.integer && value != std::floor(value)) {
    throw ConfigError(std::string(name),
                      shown + " is not an integer; allowed range " + decl.RangeText());
  }
  decl.set(params, value);
}

double GetParam(const Params& params, std::string_view name) {
  return RequireParam(name).get(params);
}

std::pair<std::string, double> ParseAssignment(std::string_view assignment) {
  const size_t eq = assignment.find('=');
  if (eq == std::string_view::npos || eq == 0) {
    throw ConfigError("", "expected NAME=VALUE, got '" + SafeText(assignment) + "'");
  }
  const std::string_view name = assignment.substr(0, eq);
  double value = 0;
  if (const std::string why = ReadNumber(assignment.substr(eq + 1), value); !why.empty()) {
    throw ConfigError(SafeText(name), why);
  }
  return {std::string(name), value};
}

void SetParamFromString(Params& params, std::string_view assignment) {
  const size_t eq = assignment.find('=');
  if (eq == std::string_view::npos || eq == 0) {
    throw ConfigError("--set", "expected NAME=VALUE, got '" + SafeText(assignment) + "'");
  }
  const std::string_view name = assignment.substr(0, eq);
  const ParamDecl& decl = RequireParam(name);
  double value = 0;
  if (const std::string why = ReadNumber(assignment.substr(eq + 1), value); !why.empty()) {
    throw ConfigError(std::string(name), why + "; allowed range " + decl.RangeText());
  }
  SetParam(params, name, value);
}

}  // namespace dysa
