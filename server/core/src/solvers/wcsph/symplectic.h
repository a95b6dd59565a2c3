// wcsph's second-order time integration (Params::time_integration = 1): the predictor-corrector
// Symplectic scheme of DualSPHysics (Dominguez et al. 2022, "DualSPHysics: from fluid dynamics
// to multiphysics problems", Comput. Part. Mech. 9, 867-895), after Leimkuhler, Reich
// and Skeel 1996 and Monaghan 2005 ("Smoothed particle hydrodynamics", Rep. Prog. Phys. 68,
// 1703-1759). With a^n, (D rho / Dt)^n the forces of the state at t and dt the CFL step
// chosen from them:
//   predictor  x^(n+1/2) = x^n + dt/2 v^n,  v^(n+1/2) = v^n + dt/2 a^n,
//              rho^(n+1/2) = rho^n + dt/2 (D rho / Dt)^n;
//   the forces again, at t + dt/2 from the predicted state (a fresh neighbour sort, the
//   obstacles and the gravity ramp at t + dt/2): a^(n+1/2), (D rho / Dt)^(n+1/2);
//   corrector  v^(n+1) = v^n + dt a^(n+1/2),  x^(n+1) = x^n + dt/2 (v^n + v^(n+1)),
//              rho^(n+1) = rho^n (2 - e) / (2 + e),  e = -(D rho / Dt)^(n+1/2) dt / rho^(n+1/2),
//              DualSPHysics's form of rho^n + dt (D rho / Dt)^(n+1/2) (equal to first order in e)
//              that keeps the density positive whatever the rate.
// Second order in dt where the symplectic Euler step (Integrate) is first order, at two force
// evaluations per step; DualSPHysics's Test 2 and dam break cases use it. The wall contact
// (LimitApproachToSurfaces) cuts the drift velocity of each half against the surfaces over that
// half, as Integrate does over the step, and the last-resort clamp acts on the result. Particle
// shifting (particle_shifting.h), where it is on, is computed from the half step's state and
// added to the corrector's drift.
#pragma once

#include <string_view>

#include "solvers/wcsph/becker_teschner_solver.h"

namespace dysa::wcsph {

// The force passes of the half step carry their first evaluation's names with this suffix
// ("density_corrector"), so that each is timed on its own.
inline constexpr std::string_view kCorrectorSuffix = "_corrector";

// The `predict` pass, after the time step: keeps x^n, v^n, rho^n (data.step_start) and moves
// the state to t + dt/2 (state.time included, for the passes that follow).
void PredictHalfStep(const Model& model, BeckerTeschnerData& data, State& state);
// The `correct` pass, last: the step from x^n, v^n, rho^n with the forces of the half step;
// restores state.time to t (the simulation advances it by dt).
void CorrectStep(const Model& model, BeckerTeschnerData& data, State& state);

}  // namespace dysa::wcsph
