// Validation cases of the physical solvers against analytic and experimental references
// (/work/shared/reference/README.md; `dysa validate` prints them, tests/validation asserts them).
// Each runs a built-in scene of scenes/validation/, optionally at another particle spacing.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "dysa/core/device.h"
#include "dysa/core/scene.h"

namespace dysa {

struct ValidationRun {
  std::string solver;
  double spacing = 0;    // m
  size_t particles = 0;  // fluid particles
  uint64_t steps = 0;
  double time = 0;  // s, simulated
};

// The scene's fluid slab (domain and blocks between z walls) made `layers` particles of spacing
// d thick, and particle_spacing set to d. The validation scenes are 3D slabs standing for 2D
// experiments; a finer spacing keeps the slab as many particles thick.
inline constexpr int kSlabLayers = 4;
Scene SlabAtSpacing(Scene scene, double spacing, int layers = kSlabLayers);

// Hydrostatic tank (Adami, Hu, Adams 2012): `hydrostatic_tank`, water of depth H at rest
// under gravity g ramped in over 1 s, run to its end_time. Pressure is sampled along the
// vertical line through the tank's centre (x = 1, mid-slab) every spacing from y = d up to
// H - top_layers * d (the free surface's kernel deficit leaves the top layers under-pressured
// by construction), averaged after every step over the run's last kHydrostaticAveragingTime
// (weighted by the step's length), and compared with rho0 g (H - y). The average takes out
// wcsph's acoustic ringing (period 2 H / c0 = 0.09 s) and dfsph's step-to-step noise: its
// pressure is the impulse of two iterative solves, each stopped at a tolerance, and it swings
// by half its value from one step to the next, so samples at a fixed interval (every other
// step) would read one phase of it.
struct HydrostaticResult {
  ValidationRun run;
  double depth = 0;                // m, H (the fluid block's height)
  double pressure_error_max = 0;   // max |p - rho0 g (H - y)| / (rho0 g H) over the samples
  double pressure_error_mean = 0;  // mean of the same
  // Pa/m, -dp/dy of the least-squares line through the samples: rho0 g for the right gradient,
  // whatever the offset.
  double pressure_gradient = 0;
  // Compression: max(0, rho_i / rho0 - 1) over every fluid particle (a free surface's kernel
  // deficit is not an error of the solver), mean and max.
  double density_error_mean = 0;
  double density_error_max = 0;
  double max_speed = 0;  // m/s at the end: the tank should be at rest
  // Mean height of the bottom layer (the fluid particles less than d above the floor) over d,
  // at the end: 0.5 when the wall's pressure holds the fluid on the rest lattice, lower when it
  // sank into the wall contact force's range (0.4 d).
  double bottom_layer_height = 0;
  // How far the fluid's centre of mass sank from the start to the end, in d: a column that
  // holds its rest lattice sinks by its compression only (wcsph, 0.22% at the floor: a few
  // hundredths of d); one whose layers re-stack into a denser packing sinks further.
  double settling = 0;
  // An iterative solver's (dfsph) solves that stopped at max_iterations, over the run.
  uint64_t capped_solves = 0;
  // How far the window's mean pressure could move by chance: the largest, over the samples,
  // standard error of that mean (BatchMeansStandardError over kHydrostaticBatches equal parts
  // of the window), over rho0 g H. Two runs whose errors differ by less than about twice it
  // are not distinguishable by this measurement.
  double pressure_error_uncertainty = 0;
  struct Sample {
    double y, pressure, reference;  // m, Pa, Pa
    double standard_error;          // Pa, of the window's mean pressure
  };
  std::vector<Sample> profile;  // the averaged pressure
  int samples = 0;              // pressure samples averaged: one after every step of the window
};
inline constexpr int kHydrostaticTopLayers = 3;
inline constexpr double kHydrostaticAveragingTime = 0.5;  // s
// Parts of the averaging window for the standard error: 0.1 s each, longer than wcsph's
// acoustic period (0.09 s), so that neighbouring parts are nearly independent.
inline constexpr int kHydrostaticBatches = 5;

// The standard error of the mean of a correlated series by the method of batch means: the
// series cut into B consecutive equal parts with means m_b and overall mean m,
// sqrt(sum_b (m_b - m)^2 / (B (B - 1))). Valid when the parts are longer than the series'
// correlation time (dfsph's pressure alternates from one step to the next, so its samples are
// far from independent, and the plain sample formula would be wrong). 0 for fewer than 2 parts.
double BatchMeansStandardError(const std::vector<double>& batch_means);

// How to run a case: the scene's own resolution and solver unless given; `sets` are
// NAME=VALUE parameter overrides applied last (as `dysa run --set`).
struct ValidationOptions {
  std::optional<double> spacing;  // m, see SlabAtSpacing
  // Particles across the slab, [1, 64]: more keeps the side walls away from more of the fluid.
  int slab_layers = kSlabLayers;
  std::string solver;  // "": the scene's (wcsph)
  std::vector<std::string> sets;
  // Where the cases step; a solver without a GPU backend throws ConfigError("device", ...).
  Device device;
  // Dam breaks only: stop at the front table's end (T = 2.96, tau = 2.09) instead of running on
  // to the residual-height table's (tau = 3.44); DamBreakResult::heights is then empty.
  bool front_only = false;
};
HydrostaticResult RunHydrostaticTank(const ValidationOptions& options = {});

// Dam break against Martin & Moyce 1952 (`dam_break_martin_moyce`): a column a wide and 2a
// tall collapses; the surge front Z = (x_front + d/2) / a (the particles' extent, not their
// centres) is compared with the experiment at each tabulated T = t sqrt(2 g / a).
// Martin & Moyce 1952, collapse of a liquid column, n^2 = 2 (column width a, height 2a): the
// surge front Z = x/a against T = t sqrt(2 g / a), as tabulated in
// server/validation/data/dam_break_martin_moyce_1952_front.csv (embedded at build time, parsed on
// first use).
struct MartinMoyceRow {
  double T, Z;
};
const std::vector<MartinMoyceRow>& MartinMoyce1952Front();

// A simulated front Z at time T (same units), sampled in increasing T from T = 0.
struct FrontSample {
  double T, Z;
};

// RMS and max of |Z_sim(T - delay) - Z_ref(T)| / Z_ref(T) over the rows with T > 0.
struct FrontError {
  double rms = 0, max = 0;
};

// Where the error of a simulated front lies, for the report (not a target): a constant lag of
// the experiment (its column was released over a finite time, the simulation's at once) and
// the surge's speed.
struct FrontDiagnostics {
  // The delay s, in T, that minimises the RMS error of Z_sim(T - s) against Z_ref(T) over the
  // table's rows with T > 0 (searched in [0, 1] by 0.001; before T = 0 the column is at rest),
  // and the errors with it.
  double release_delay = 0;
  FrontError delayed;
  // The errors with a fixed delay chosen elsewhere: kPublishedReleaseDelay.
  FrontError published;
  // dZ/dT of the least-squares lines through the simulated and the tabulated front at the
  // table's times from kSurgeFrom on: the surge's speed, whatever its offset.
  double front_speed = 0;
  double front_speed_ref = 0;
};
inline constexpr double kSurgeFrom = 1.19;  // T, the table's row where the surge has formed
// The time correction (in T) the Lethe CFD code's dam-break example adds to its simulated times
// before it compares them with this table (examples/multiphysics/dam-break/dam-break-2d.py):
// a delay chosen independently of this project's runs.
inline constexpr double kPublishedReleaseDelay = 0.175;

FrontError FrontErrorWithDelay(const std::vector<FrontSample>& trace,
                               const std::vector<MartinMoyceRow>& table, double delay);
FrontDiagnostics DiagnoseFront(const std::vector<FrontSample>& trace,
                               const std::vector<MartinMoyceRow>& table);

// Martin & Moyce 1952's second table for the same column (n^2 = 2): the residual height of the
// column at the wall, H = eta / (2 a), against tau = t sqrt(g / a), as tabulated in
// server/validation/data/dam_break_martin_moyce_1952_height.csv (as the front's).
struct MartinMoyceHeightRow {
  double tau, H;
};
const std::vector<MartinMoyceHeightRow>& MartinMoyce1952ResidualHeight();

struct DamBreakResult {
  ValidationRun run;
  double column_width = 0;  // m, a
  double time_unit = 0;     // s per unit of T: sqrt(a / (2 g))
  double rms_error = 0;     // RMS of |Z - Z_ref| / Z_ref over the table, T > 0
  double max_error = 0;
  struct Row {
    double T, Z, Z_ref;
  };
  std::vector<Row> rows;
  std::vector<FrontSample> trace;  // the front after every step
  FrontDiagnostics diagnostics;
  // The residual column at the wall against MartinMoyce1952ResidualHeight(): eta is
  // ConnectedColumnHeight at x = the wall, mid-slab, over a horizontal radius of one kernel
  // support (gap: one kernel support) plus the half spacing, H = eta / (2 a); the run goes on to
  // the table's last tau (3.44, T = tau sqrt(2) = 4.86).
  struct HeightRow {
    double tau, H, H_ref;
  };
  std::vector<HeightRow> heights;
  double height_rms_error = 0;  // RMS of |H - H_ref| / H_ref over the table
  double height_max_error = 0;
};
DamBreakResult RunDamBreak(const ValidationOptions& options = {});
// The same with the release modelled (`dam_break_martin_moyce_gate`): a gate at x = a lifted at
// a documented speed (the scene's description and docs/validation.md give it and its source)
// instead of the column released at once; t = 0 is the start of the lift.
DamBreakResult RunGatedDamBreak(const ValidationOptions& options = {});

// Start-up of Poiseuille flow (Morris, Fox, Zhu 1997, "Modeling low Reynolds number
// incompressible flows using SPH", J. Comput. Phys. 136, sec. 4.1): `poiseuille_flow`, fluid at
// rest between no-slip walls at x = 0 and x = L, driven along -y by a body force F (the scene's
// gravity), periodic in y and z. It checks what the tank and the dam break do not: the viscous
// term (the tank is at rest; the dam break's Reynolds number, 4e4, leaves it no part) and the
// no-slip walls. The velocity of each column of particles (x within one spacing) is compared
// with the analytic series at kPoiseuilleTimes, as a fraction of the final centre speed
// u_max = F L^2 / (8 nu). Other spacings keep the channel's periodic y 8 and z 6 particles long
// (6: a period of 3 kernel supports, the least the neighbour grid takes).
struct PoiseuilleResult {
  ValidationRun run;
  double width = 0;       // m, L
  double force = 0;       // m/s^2, F (along -y)
  double viscosity = 0;   // m^2/s, nu
  double peak_speed = 0;  // m/s, u_max = F L^2 / (8 nu), the steady centre speed
  struct Profile {
    double t = 0;                   // s
    std::vector<double> x;          // m, column centres
    std::vector<double> speed;      // m/s, mean -v_y of the column's particles
    std::vector<double> reference;  // m/s, MorrisPoiseuilleSpeed
    double error_max = 0;           // max |speed - reference| / u_max
  };
  std::vector<Profile> profiles;  // at kPoiseuilleTimes
  double error_max = 0;           // over all the profiles
};
// Morris et al.'s times (their Fig. 2), the last one steady to 5e-5 (L^2 / nu = 1 s).
inline constexpr double kPoiseuilleTimes[] = {0.0225, 0.045, 0.1125, 0.225, 1.0};
inline constexpr int kPoiseuilleLayers[2] = {8, 6};  // the periodic y and z, in spacings
// The speed -v_y at x and t of the start-up (Morris et al. eq. 21, 200 terms):
// F x (L - x) / (2 nu) - sum_n 4 F L^2 / (nu pi^3 (2n+1)^3) sin(pi x (2n+1) / L)
// exp(-(2n+1)^2 pi^2 nu t / L^2).
double MorrisPoiseuilleSpeed(double x, double t, double force, double viscosity, double width);
PoiseuilleResult RunPoiseuille(const ValidationOptions& options = {});

}  // namespace dysa
