// Particle shifting (Params::particle_shifting): Lind, Xu, Stansby, Rogers 2012 ("Incompressible
// smoothed particle hydrodynamics for free-surface flows: a generalised diffusion-based algorithm
// for stability and validations for impulsive flows and propagating waves", J. Comput. Phys.
// 231, 1499-1523) in the form of Skillen, Lind, Stansby, Rogers 2013 (Comput. Methods Appl.
// Mech. Engrg. 265, 163-173) that DualSPHysics uses: each step moves a particle, besides its
// velocity, by
//   dr_i = -A h |v_i| dt grad C_i,   grad C_i = sum_j (m / rho_j) grad W_ij + sum_b V_b grad W_ib,
// down the gradient of the particle concentration, which spreads clumps and fills voids before
// they grow into the pressure noise and the tensile voids of a violent flow (the impact of
// SPHERIC Test 2). A (particle_shifting, 0: off) is dimensionless; 1-6 is the literature's range
// (Skillen et al.: 2). The boundary particles count as particles, so that a particle next to a
// wall is not pushed into it. At a free surface grad C points out of the fluid and the shift
// would pull the surface in: particles whose position divergence
//   div r_i = -sum_j (m / rho_j) x_ij . grad W_ij - sum_b V_b x_ib . grad W_ib
// (3 mu inside the fluid, about 1.5 on a flat surface) is below kFreeSurfaceDivergence are not
// shifted (DualSPHysics's ShiftTFS, its 3-D value). The shift moves particles, not fluid: the
// carried density and the velocity stay with the particle (as in DualSPHysics).
#pragma once

#include "dysa/core/model.h"
#include "dysa/core/state.h"
#include "solvers/physical/physical_data.h"

namespace dysa::physical {

// div r below which a particle counts as on the free surface and is not shifted.
inline constexpr double kFreeSurfaceDivergence = 2.75;

// The `shifting` pass: data.shift = -A h |v_i| grad C_i (m/s; the integration adds shift dt to
// the displacement), 0 on the free surface. Reads the positions, velocities and densities.
void ComputeParticleShifting(const Model& model, PhysicalData& data, State& state);

}  // namespace dysa::physical
