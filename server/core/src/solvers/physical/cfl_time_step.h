// The CFL-adaptive time step of the physical solvers.
//
// With h the smoothing length (the particle spacing d: the cubic spline's support is 2 h), the
// step honours the three limits usual in SPH (Monaghan 1992; Morris, Fox, Zhu 1997; Becker &
// Teschner 2007, sec. 3.4):
//   sound / CFL  dt <= lambda h / (c + v_max)        lambda = cfl_factor (default 0.25)
//                c the speed of sound of the densest particle, c0 (rho_max / rho0)^3 (the Tait
//                equation's dp/drho = c0^2 (rho / rho0)^6): a fluid compressed by an impact or
//                a strong gravity is stiffer than at rest, and a step sized by c0 lets it gain
//                energy (tests/stress, bench/stress_bench)
//   viscous      dt <= 0.125 lambda h^2 / nu      lambda the viscosity moment (kernels.h, 0.708)
//                The viscosity term is divided by lambda to give the fluid its viscosity nu;
//                its fastest (compressive, grid-scale) mode then decays at 20.6 nu / h^2, which
//                explicit steps hold for dt < 0.097 h^2 / nu: 0.125 h^2 / nu would not be
//                stable (Poiseuille flow blew up), 0.0885 h^2 / nu is. wcsph's artificial
//                viscosity alpha (becker_teschner_solver.h) adds lambda alpha s h c0 / 10 to nu
//                here, s = smoothing_length_ratio (its term is the laminar one with
//                nu = alpha s h c0 / 10, over approaching pairs, without the division by lambda),
//                so that the two together stay stable: alone it gives dt <= 1.25 h / (alpha s c0),
//                which binds only where alpha s cfl_factor > 1.25 (the sound limit is at most
//                cfl_factor h / c0): never at s = 1. DualSPHysics bounds its step by
//                h / (c + max_ij h |v_ij . x_ij| / (r^2 + 0.01 h^2)) instead; that maximum is
//                about |v_ij| <= 2 v_max at the lattice spacing, which the sound limit's v_max
//                covers within a factor 2 on a term ten times smaller than c (c0 >= 10 v_max).
//   force        dt <= 0.25 sqrt(h / |a|_max)
// and dt <= max_time_step. The step is chosen each step from the velocities and accelerations
// of that step, so nothing about it carries over between steps.
#pragma once

#include <limits>
#include <string>

#include "dysa/core/model.h"
#include "dysa/core/state.h"
#include "solvers/physical/physical_data.h"

namespace dysa {

struct TimeStepLimits {
  static constexpr double kNone = std::numeric_limits<double>::infinity();
  double sound = kNone;    // s
  double viscous = kNone;  // s; none when nu = 0
  double force = kNone;    // s; none when every acceleration is 0
  double max = kNone;      // s, max_time_step
  double Min() const;
};

// A weakly compressible solver's warning when the flow outruns its speed of sound (Mach > 1,
// speed in m/s): the model assumes density changes of order (v / c0)^2, a few percent at most,
// and past c0 an impact compresses the fluid by its whole density, so the step is computed but
// not accurate (a block falling at 2 m/s with c0 = 0.1 m/s gains kinetic energy that gravity
// never gave it). "" when the flow is subsonic. The usual rule is c0 >= 10 v_max.
std::string SupersonicWarning(const Params& params, double speed);

// The largest CFL factor an incompressible (pressure-projection) solver steps with: past it a
// particle crosses most of a spacing per step, the density solve meets compressions it cannot
// remove and the fluid blows apart (tests/stress). A larger cfl_factor is taken as this, with a
// warning.
inline constexpr double kIncompressibleMaxCfl = 0.3;

// `acoustic`: the sound limit of a weakly compressible solver, with the speed of sound at
// density `density_max` (kg/m^3; at most rest density counts as rest density); an
// incompressible one (dfsph) takes lambda h / v_max instead (none when nothing moves).
TimeStepLimits CflLimits(const Model& model, double v_max, double a_max, bool acoustic = true,
                         double density_max = 0);

// The step for `limits` when at most `until` seconds remain before a point the step must not
// pass (the end of a frame): the limit itself; all that remains when it fits; half of it when
// it would take two steps anyway (so no sliver of a step is left).
double ChooseTimeStep(const TimeStepLimits& limits, double until);

// The `time_step` pass: v_max and |a|_max over the particles (their velocities, and the
// accelerations of this step in data.acceleration), then state.dt = ChooseTimeStep(...,
// state.max_dt).
void ChooseTimeStepPass(const Model& model, physical::PhysicalData& data, State& state);
// The same without the speed of sound (dfsph).
void ChooseIncompressibleTimeStepPass(const Model& model, physical::PhysicalData& data,
                                      State& state);

}  // namespace dysa
