#include "solvers/physical/cfl_time_step.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>

#include "solvers/physical/physical_passes.h"

namespace dysa {

double TimeStepLimits::Min() const { return std::min({sound, viscous, force, max}); }

TimeStepLimits CflLimits(const Model& model, double v_max, double a_max, bool acoustic,
                         double density_max) {
  const Params& params = model.params;
  const double h = params.particle_spacing;
  TimeStepLimits limits;
  // c = c0 (rho / rho0)^((gamma - 1) / 2) of the Tait equation, gamma = 7.
  const double compression = std::max(1.0, density_max / params.rest_density);
  const double sound = params.speed_of_sound * compression * compression * compression;
  static_assert(physical::kTaitExponent == 7);
  const double speed = acoustic ? sound + v_max : v_max;
  const double cfl =
      acoustic ? params.cfl_factor : std::min(params.cfl_factor, kIncompressibleMaxCfl);
  if (speed > 0) limits.sound = cfl * h / speed;
  // wcsph's artificial viscosity (the acoustic solver's alone) is the laminar term with
  // nu = alpha h_s c0 / 10 (h_s the smoothing length), not divided by lambda: the laminar
  // viscosity lambda alpha h_s c0 / 10 in this limit's terms. The two damp the same grid-scale
  // mode, so their rates add. With alpha = 0, nu + 0 is nu: the limit is what it was.
  const double artificial = acoustic ? model.viscosity_moment * params.artificial_viscosity *
                                           params.speed_of_sound * model.SmoothingLength() / 10
                                     : 0;
  const double nu = params.kinematic_viscosity + artificial;
  if (nu > 0) limits.viscous = 0.125 * model.viscosity_moment * h * h / nu;
  if (a_max > 0) limits.force = 0.25 * std::sqrt(h / a_max);
  limits.max = params.max_time_step;
  return limits;
}

double ChooseTimeStep(const TimeStepLimits& limits, double until) {
  const double dt = limits.Min();
  if (!(until > 0)) return dt;
  if (until <= dt) return until;
  if (until < 2 * dt) return 0.5 * until;
  return dt;
}

std::string SupersonicWarning(const Params& params, double speed) {
  if (!(speed > params.speed_of_sound)) return "";
  return "the flow reaches " + std::to_string(speed) + " m/s, faster than speed_of_sound " +
         std::to_string(params.speed_of_sound) +
         " m/s: the weakly compressible model does not hold (take c0 >= 10 v_max)";
}

namespace {

void ChooseStep(const Model& model, const physical::PhysicalData& data, State& state,
                bool acoustic) {
  const ParticleArrays& p = state.particles;
  const int64_t n = int64_t(p.size());
  // Maxima are exact whatever the order they are taken in, so the reduction is deterministic.
  // Ghosts (ProcessShare) are left out: their accelerations are incomplete.
  const uint8_t* ghost = state.share.ghost.empty() ? nullptr : state.share.ghost.data();
  Real v2_max = 0;
  Real a2_max = 0;
  Real density_max = 0;
#pragma omp parallel for schedule(static) reduction(max : v2_max, a2_max, density_max)
  for (int64_t i = 0; i < n; ++i) {
    if (ghost && ghost[i]) continue;
    v2_max = std::max(v2_max, p.velocity[i].squaredNorm());
    a2_max = std::max(a2_max, data.acceleration[i].squaredNorm());
    density_max = std::max(density_max, p.density[i]);
  }
  // A float converts to double exactly, so the maxima over the processes are those of one.
  double maxima[3] = {double(v2_max), double(a2_max), double(density_max)};
  if (state.share.max_over_processes) state.share.max_over_processes(maxima);
  // A moving obstacle's samples may not cross more of a spacing per step than the fluid.
  const double v_max = std::max(std::sqrt(maxima[0]), data.max_obstacle_speed);
  const TimeStepLimits limits = CflLimits(model, v_max, std::sqrt(maxima[1]), acoustic, maxima[2]);
  state.dt = ChooseTimeStep(limits, state.max_dt);
  if (acoustic) {
    if (std::string warning = SupersonicWarning(model.params, v_max); !warning.empty()) {
      state.warning = std::move(warning);
    }
  }
}

}  // namespace

void ChooseTimeStepPass(const Model& model, physical::PhysicalData& data, State& state) {
  ChooseStep(model, data, state, true);
}

void ChooseIncompressibleTimeStepPass(const Model& model, physical::PhysicalData& data,
                                      State& state) {
  ChooseStep(model, data, state, false);
  if (model.params.cfl_factor > kIncompressibleMaxCfl) {
    state.warning = "cfl_factor " + std::to_string(model.params.cfl_factor) +
                    " is beyond the incompressible solver's stability limit; steps use " +
                    std::to_string(kIncompressibleMaxCfl);
  }
}

}  // namespace dysa
