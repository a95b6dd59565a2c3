#include "solvers/wcsph/symplectic.h"

#include <vector>

#include "solvers/domain_walls.h"
#include "solvers/physical/physical_passes.h"

namespace dysa::wcsph {

void PredictHalfStep(const Model& model, BeckerTeschnerData& data, State& state) {
  ParticleArrays& p = state.particles;
  BeckerTeschnerData::StepStart& start = data.step_start;
  const Real half = Real(state.dt * 0.5);
  const int64_t n = int64_t(p.size());
  const std::vector<physical::ObstacleFrame> frames =
      physical::ObstacleFramesOverStep(model, state.time, state.dt * 0.5);
  start.position.resize(p.size());
  start.velocity.resize(p.size());
  start.density.resize(p.size());
  const Real rho_lo = Real(model.params.rest_density * model.params.carried_density_min);
  const Real rho_hi = Real(model.params.rest_density * kCarriedDensityMax);
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    start.position[i] = p.position[i];
    start.velocity[i] = p.velocity[i];
    start.density[i] = data.density[i];
    // x^(n+1/2) = x^n + dt/2 v^n, the drift cut by the wall contact over the half step.
    Vec3 drift = p.velocity[i];
    physical::LimitApproachToSurfaces(model, frames, half, p.position[i], drift);
    p.position[i] += drift * half;
    CollideWithDomainWalls(model.domain, model.periodic, Real(0), p.position[i], drift);
    p.velocity[i] += data.acceleration[i] * half;
    data.density[i] =
        BoundCarriedDensity(data.density[i] + data.density_rate[i] * half, rho_lo, rho_hi);
    p.density[i] = data.density[i];
  }
  start.time = state.time;
  start.predicted = true;
  state.time = start.time + state.dt * 0.5;
}

void CorrectStep(const Model& model, BeckerTeschnerData& data, State& state) {
  ParticleArrays& p = state.particles;
  BeckerTeschnerData::StepStart& start = data.step_start;
  const Real dt = Real(state.dt);
  const int64_t n = int64_t(p.size());
  const std::vector<physical::ObstacleFrame> frames =
      physical::ObstacleFramesOverStep(model, start.time, state.dt);
  const Vec3* shift = model.params.particle_shifting > 0 ? data.shift.data() : nullptr;
  const Real rho_lo = Real(model.params.rest_density * model.params.carried_density_min);
  const Real rho_hi = Real(model.params.rest_density * kCarriedDensityMax);
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    const Vec3& x0 = start.position[i];
    const Vec3& v0 = start.velocity[i];
    // v^(n+1) = v^n + dt a^(n+1/2); x^(n+1) = x^n + dt (v^n + v^(n+1)) / 2, each velocity cut
    // by the contact over the step from x^n.
    Vec3 v = v0 + data.acceleration[i] * dt;
    physical::LimitApproachToSurfaces(model, frames, dt, x0, v);
    Vec3 drift = (v0 + v) * Real(0.5);
    if (shift != nullptr) drift += shift[i];  // the particle shifting's (particle_shifting.h)
    physical::LimitApproachToSurfaces(model, frames, dt, x0, drift);
    p.position[i] = x0 + drift * dt;
    CollideWithDomainWalls(model.domain, model.periodic, Real(0), p.position[i], v);
    p.velocity[i] = v;
    // rho^(n+1) = rho^n (2 - e) / (2 + e), e = -(D rho / Dt)^(n+1/2) dt / rho^(n+1/2), held
    // within the carried density's range (e <= -2 would make it negative or infinite)
    const Real e = -data.density_rate[i] * dt / data.density[i];
    data.density[i] =
        BoundCarriedDensity(start.density[i] * (Real(2) - e) / (Real(2) + e), rho_lo, rho_hi);
    p.density[i] = data.density[i];
  }
  start.predicted = false;
  state.time = start.time;
}

}  // namespace dysa::wcsph
