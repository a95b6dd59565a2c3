// Probes: scalar measurements of the state written as CSV columns by offline runs.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "dysa/core/model.h"
#include "dysa/core/scene.h"
#include "dysa/core/state.h"

namespace dysa {

// Column names, in order: one per probe, two for a density probe (NAME_mean, NAME_max), three
// for a box force (NAME_x, NAME_y, NAME_z).
std::vector<std::string> ProbeColumns(std::span<const ProbeSpec> probes);

// The height above `floor` of the water column standing at (x, z) of `point`: the particles
// within `radius` of it horizontally, taken upwards from the floor while each is at most `gap`
// above the one below it (the first at most `gap` above the floor). A drop or a sheet of spray
// separated from the column by more than `gap` is not counted, however high it flies. Returns
// the highest counted particle's centre above the floor (a caller adds the half spacing to
// the surface it stands for), 0 when no particle is within `gap` of the floor there.
double ConnectedColumnHeight(const ParticleArrays& particles, const Model& model,
                             const Vec3d& point, double radius, double gap, double floor);

// The pressure a flush-mounted sensor at `point` reads, from the fluid particles alone (so it is
// the same on every solver and device): the Shepard interpolation over the kernel support
//   p_s = sum_f (p_f + rho_f g . (x_s - x_f)) W(|x_s - x_f|) / sum_f W(|x_s - x_f|)
// with the model's kernel, the hydrostatic correction carrying each particle's pressure to the
// sensor's height, as wcsph extrapolates the fluid's pressure to its boundary particles (Adami,
// Hu, Adams 2012, eq. 27, without the wall's acceleration: the walls do not move). Where
// `normal` is not zero only the particles on its side of the face count ((x_f - x_s) . n > 0),
// so a sensor near an edge does not read the water beyond it. g is the gravity at `time`
// (gravity_ramp_time included). Not negative (a gauge pressure under the fluid's, which the
// solvers clamp at 0 too); 0 where no particle is within the support (a dry sensor).
double WallPressureAt(const ParticleArrays& particles, const Model& model, const Vec3d& point,
                      const Vec3d& normal, double time);

// The fluid's pressure force on the box obstacle model.boxes[box] where it stands at `time`, N:
// the wall pressure (WallPressureAt, each face's outward normal) integrated over the box's six
// faces, F = - sum_faces sum_patches p n dA. Each face is cut into equal patches of side at most
// `spacing` m (0: the kernel's support, the width the pressure field is averaged over anyway; at
// most 1000 patches along an edge) and read at their centres. A face with no fluid on its
// side (on the floor, against a wall) adds nothing. The probe box_force writes it as NAME_x,
// NAME_y, NAME_z. Throws std::out_of_range for a box the model does not have.
Vec3d BoxForceOn(const ParticleArrays& particles, const Model& model, int box, double spacing,
                 double time);

// The values of every probe for the current state, in ProbeColumns() order.
std::vector<double> EvaluateProbes(std::span<const ProbeSpec> probes, const Model& model,
                                   const State& state);

}  // namespace dysa
