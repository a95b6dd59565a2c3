// dfsph's walls: each boundary particle takes the pressure of the fluid around it, extrapolated
// as wcsph's boundary_pressure pass does (Adami, Hu, Adams 2012, "A generalized wall boundary
// condition for SPH", J. Comput. Phys. 231, eq. 27), instead of Akinci's mirror p_b = p_i:
//   p_b = sum_i w_bi p_i + max(0, g . sum_i w_bi rho_i (x_b - x_i)),
//   w_bi = W(x_b - x_i) / sum_k W(x_b - x_k) over the fluid neighbours of b (Shepard weights).
// The first part is solved for: each Jacobi iteration of both solves extrapolates the
// iteration's kappa_i / rho_i to kappa_b / rho_b the same way (ExtrapolateKappa), and the wall
// term of the pressure force becomes symmetric like the fluid's,
//   a_i -= sum_b Psi_b (kappa_i / rho_i + kappa_b / rho_b) grad W_ib.
// The second, the hydrostatic head between b and its neighbours, is known before the solves
// and acts as a fixed acceleration, a_i = -sum_b Psi_b p_hyd_b / (rho_i^2 mu) grad W_ib (mu:
// the gradient moment, as the solvers' pressure). Clamped at zero as Adami's total is: a wall
// particle above the fluid would otherwise pull it.
//
// Why: with the mirror, a particle next to a wall feels the fluid side's pressure twice
// (kappa_i + kappa_j) and the wall's once (kappa_i alone), so the fluid's weight pushes the
// bottom layer into the floor until the wall contact force holds it (0.40 d instead of d / 2);
// the layers above re-stack and the reported pressure missed rho0 g (H - y) by 16% in the
// hydrostatic tank (tests/validation). The mirror doubled (p_b = p_i in the symmetric form)
// held a thick slab, but in slabs 4 to 6 particles thick a sideways motion next to the side
// walls grew until it threw the column up; Band et al. 2018 ("Pressure boundaries for
// implicit incompressible SPH", ACM TOG 37(2)) describe the mirror's defects in implicit
// solvers and solve for boundary pressures; the extrapolation here is the explicit form.
#pragma once

#include "dysa/core/model.h"
#include "dysa/core/state.h"
#include "solvers/dfsph/bender_koschier_data.h"

namespace dysa::dfsph {

// Lists data.boundary_neighbors from data.boundary_pairs (the density pass's) with their
// Shepard weights and hydrostatic pressure, and sets data.acceleration to the walls'
// hydrostatic acceleration (the external_forces pass adds gravity to it).
void ListBoundaryNeighbors(const Model& model, BenderKoschierData& data, State& state);

// neighbors.kappa[b] = sum_i w_bi kappa_over_rho[i].
void ExtrapolateKappa(const Real* kappa_over_rho, BoundaryNeighbors& neighbors);

}  // namespace dysa::dfsph
