// The tunable parameters of a simulation and their single declaration table.
//
// Every parameter is declared once, in ParamTable(), with its name, unit, range, default,
// whether changing it needs a reset and which solvers read it. Scene parsing, `dysa run --set`,
// the RPC layer and the viewer's sliders all read that table; nothing else lists parameters
// (scenes/README.md's table is tested against it).
#pragma once

#include <span>
#include <string>
#include <string_view>
#include <utility>

namespace dysa {

// Defaults are the thesis's basic scene (scenes/seed_basic.json). Units: metres, seconds,
// kilograms; the seed model's densities are kernel sums times the particle mass (kg/m^3).
struct Params {
  // Time stepping: one frame is `iterations_per_frame` steps of
  // dt = time_scale / (frame_rate * iterations_per_frame) simulated seconds.
  double time_scale = 1.0;  // simulation speed, simulated s per displayed-frame second
  int iterations_per_frame = 3;
  double frame_rate = 60.0;  // frames per second (Hz)

  double gravity = -10.0;                  // m/s^2 along +y
  double collision_damping = 0.086;        // fraction of the normal speed kept after hitting a wall
  double smoothing_radius = 0.2;           // m, kernel support h; also the neighbour grid cell size
  double target_density = 630.0;           // kg/m^3, rest density rho0 of the equation of state
  double pressure_multiplier = 28.8;       // m^2/s^2: p = (rho - rho0) * k, in Pa
  double near_pressure_multiplier = 2.25;  // m^2/s^2: p_near = rho_near * k_near
  double viscosity = 0.001;                // m^3/s: dv_i = mu * sum_j (v_j - v_i) W(r) dt
  double particle_mass = 1.0;              // kg

  // Spawn: used by every fluid block of the scene that does not set its own value.
  int particle_quantity = 30;   // particles per axis
  double spawn_size = 5.0;      // m, edge of the spawn cube
  double spawn_jitter = 0.035;  // m, radius of the random offset added to each particle

  // Physical (SI) solvers (wcsph, dfsph; speed_of_sound wcsph only): the seed model ignores
  // these, and they ignore the seed's parameters above but for time_scale, frame_rate, gravity
  // and spawn_size (ParamDecl::solvers says which solvers read each).
  double rest_density = 1000.0;   // kg/m^3, rho0 (water)
  double particle_spacing = 0.1;  // m, lattice spacing d; mass rho0 d^3
  // The smoothing kernel (KernelKind, kernels.h): 0 the cubic spline, 1 Wendland C2.
  int kernel = 0;
  // h / d, the smoothing length over the spacing; the kernel's support is 2 h. 1 (support 2 d,
  // about 33 neighbours) is the cubic spline's classic choice; DualSPHysics's cases use
  // Wendland C2 with 1.732 (support 3.46 d, about 170 neighbours).
  double smoothing_length_ratio = 1.0;
  // The neighbour grid's cells per kernel support (NeighborGrid: 1 or 2). 2 halves the cell
  // edge: a particle's neighbour search then tests the particles of 5^3 half-support cells
  // instead of 3^3 support cells, 42% fewer candidates for the same neighbours, in another
  // order (so other float sums: the results differ in their last bits).
  int grid_cells_per_support = 1;
  double speed_of_sound = 50.0;       // m/s, c0 of the Tait equation of state
  double kinematic_viscosity = 1e-6;  // m^2/s, nu of the laminar viscosity term (water: 1e-6)
  double cfl_factor = 0.25;           // dt <= cfl_factor d / (c0 + v_max)
  double max_time_step = 0.005;       // s, upper bound of the adaptive step
  // wcsph and dfsph: the wall contact's range r0 in particle spacings: no particle comes nearer
  // than r0 / 2 to a wall or obstacle, its velocity towards the surface cut (an inelastic stop).
  double wall_contact_range = 0.4;
  double gravity_ramp_time = 0.0;  // s, gravity grows smoothly from 0 over this time (0: none)
  // wcsph only: delta of the continuity equation's density diffusion (Fourtakas et al. 2019's
  // form of delta-SPH; 0: the continuity equation without it).
  double density_diffusion = 0.1;
  // wcsph only: alpha of Monaghan's 1992 artificial viscosity between approaching particles (0:
  // off; becker_teschner_solver.h), as DualSPHysics has it (0.01 for a dam break).
  double artificial_viscosity = 0.0;
  // wcsph only: the time integration (TimeIntegration): 0 symplectic Euler, one force
  // evaluation per step; 1 the predictor-corrector Symplectic scheme, two per step, second order.
  int time_integration = 0;
  // wcsph only: A of the particle shifting dr = -A h |v| dt grad C (Lind et al. 2012; 0: off).
  double particle_shifting = 0.0;
  // wcsph only: the lower bound of the carried density over rho0 (the upper stays 1.3). 0.7 holds
  // a splash particle's density off zero; 1 keeps a tongue whose particles lack neighbours from
  // carrying less than rho0, so that it has pressure as soon as it is compressed
  // (docs/validation.md, SPHERIC Test 2).
  double carried_density_min = 0.7;
  // dfsph only: the solvers' tolerances (Bender & Koschier 2017 defaults) and iteration cap.
  double density_tolerance = 1e-4;     // mean (rho - rho0) / rho0 after the density solve
  double divergence_tolerance = 1e-3;  // mean (D rho / Dt) dt / rho0 after the divergence solve
  // Per solve. The literature's 100 (Bender & Koschier) left one density solve of the
  // validation tank (45 layers deep, 1,132 solves) at 1.01 times its tolerance, still falling
  // (a Jacobi iteration's slow smooth modes); 150 lets it finish, at no measurable cost.
  int max_iterations = 150;
  // Each solve first applies this fraction of what it applied in the previous step (warm
  // start, Bender & Koschier 2017 Sec. 4.4; 0: off). More is faster. One-signed solves keep what
  // it over-applies (1 misses the tank's 1% pressure target); signed ones take it back, and at 1
  // with them the density solve needs 23.6 iterations a step at 1 M particles against 39.6
  // (bench/README.md, "Signed corrections").
  double warm_start = 0.2;
  // 1: a solve's corrections take either sign, in half steps, and only its total is held >= 0 (a
  // projected, relaxed Jacobi iteration, as IISPH's omega 0.5 and p >= 0), so pressure that the
  // warm start over-applied is taken back where the fluid expands. 0: each iteration only adds
  // pressure (kappa >= 0, Bender & Koschier 2017), in full steps. Not the default: with
  // warm_start 1 it is 1.4 times faster and as close to the tank at 0.02 m, but at the quick
  // 0.05 m the tank's mean pressure error is 0.51% against the 0.50% target (0.19% now).
  int signed_corrections = 0;
};

struct ParamDecl {
  std::string_view name;
  std::string_view unit;  // "" for dimensionless
  std::string_view description;
  double min;  // inclusive
  double max;  // inclusive
  bool integer;
  bool needs_reset;  // a change re-spawns the particles (the state cannot carry on)
  double (*get)(const Params&);
  void (*set)(Params&, double);
  // The solvers that read it, by their SolverRegistry() names; empty: every solver. The others
  // ignore it (it is still validated and kept).
  std::span<const std::string_view> solvers;

  double DefaultValue() const { return get(Params{}); }
  bool ReadBy(std::string_view solver) const;
  // "all", or the names of `solvers` joined by ", " (help text, scenes/README.md's table).
  std::string SolversText() const;
  // "[min, max] unit", for error messages and help text.
  std::string RangeText() const;
};

std::span<const ParamDecl> ParamTable();
// nullptr when no parameter has this name.
const ParamDecl* FindParam(std::string_view name);

// Checks value against the declaration of `name` (known name, finite, in range, integral where
// required) and stores it. Throws ConfigError naming the parameter, the value (every digit it
// needs: ExactNumber) and its range; `params` is unchanged on error.
void SetParam(Params& params, std::string_view name, double value);
double GetParam(const Params& params, std::string_view name);

// Splits "NAME=VALUE" (as `dysa set` takes them) and reads VALUE, which must be a number written
// in full ("1e-3", not "1e-3x"). Throws ConfigError: with no field when there is no NAME=, else
// naming NAME when VALUE is not a number, not finite, out of the range of a double (above about
// 1.8e308 in magnitude) or so close to 0 that a double would hold 0. NAME is not looked up.
std::pair<std::string, double> ParseAssignment(std::string_view assignment);

// Parses "name=value" (as given to --set) and sets it: ParseAssignment's checks, then
// SetParam's. Throws ConfigError naming --set when there is no NAME=, else the parameter.
void SetParamFromString(Params& params, std::string_view assignment);

}  // namespace dysa
