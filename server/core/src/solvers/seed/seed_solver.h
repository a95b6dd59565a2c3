// The DySAQUASIMs thesis model (after Sebastian Lague's fluid simulation): double density
// relaxation in the form of forces.
//
// Clavet, Beaudoin, Poulin 2005, "Particle-based viscoelastic fluid simulation" (SCA): a
// pressure p = k (rho - rho0) from a spiky^2 density and a near pressure p_near = k_near
// rho_near from a spiky^3 "near density", which keeps particles apart without clustering.
// Forces use the shared pressures (p_i + p_j) / 2 over rho_i rho_j, so pairwise forces are equal
// and opposite.
// Viscosity is the thesis's velocity smoothing with the poly6 kernel (Mueller et al. 2003).
// Walls reflect the normal velocity scaled by the collision damping.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "dysa/core/solver.h"

namespace dysa::seed {

// Positions are predicted this far ahead (s) for the density and force passes, a fixed look-
// ahead as in the thesis: it damps the response to fast approach without depending on dt.
inline constexpr Real kPredictionLookahead = Real(1.0 / 120.0);

// What the seed model keeps besides the shared State, per particle in storage order, all
// rewritten every step before they are read (so a checkpoint holds none of them).
struct SeedData {
  std::vector<Vec3> predicted;     // m, positions predicted kPredictionLookahead ahead
  std::vector<Real> near_density;  // kg/m^3, Clavet et al.'s spiky^3 near density
  std::vector<Real> near_pressure;
};

class SeedSolver final : public Solver {
 public:
  std::vector<Pass> BuildPasses(const Model& model) override;
  void Reset(size_t particles) override;
  const SeedData& data() const { return data_; }

 private:
  SeedData data_;
};

std::unique_ptr<Solver> CreateSeedSolver();

// The passes, exposed for tests.
// Sorts particles by grid cell (cell edge = smoothing radius) using the predicted positions and
// reorders every per-particle array that carries over between steps into that order.
void SortParticlesIntoGrid(const Model& model, SeedData& data, State& state);
// Gravity into the velocities; the predicted positions.
void ApplyExternalForces(const Model& model, SeedData& data, State& state);
template <bool kNear>
void ComputeDensities(const Model& model, SeedData& data, State& state);
template <bool kNear>
void ApplyPressureForces(const Model& model, SeedData& data, State& state);
void ApplyViscosity(const Model& model, State& state);
void IntegrateAndCollideWithWalls(const Model& model, State& state);
// Pushes particles out of static spheres and boxes to the nearest surface point and reflects the
// normal velocity scaled by the collision damping.
void CollideWithObstacles(const Model& model, State& state);

// The step's warning when the velocity limiter of IntegrateAndCollideWithWalls slowed `limited`
// particles at step `step` (shared with the GPU backend).
std::string VelocityLimiterWarning(uint64_t limited, const Model& model, uint64_t step);

}  // namespace dysa::seed
