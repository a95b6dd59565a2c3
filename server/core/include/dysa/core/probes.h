// Probes: scalar measurements of the state written as CSV columns by offline runs.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "dysa/core/model.h"
#include "dysa/core/scene.h"
#include "dysa/core/state.h"

namespace dysa {

// Column names, in order: one per probe, two for a density probe (NAME_mean, NAME_max).
std::vector<std::string> ProbeColumns(std::span<const ProbeSpec> probes);

// The height above `floor` of the water column standing at (x, z) of `point`: the particles
// within `radius` of it horizontally, taken upwards from the floor while each is at most `gap`
// above the one below it (the first at most `gap` above the floor). A drop or a sheet of spray
// separated from the column by more than `gap` is not counted, however high it flies. Returns
// the highest counted particle's centre above the floor (a caller adds the half spacing to
// the surface it stands for), 0 when no particle is within `gap` of the floor there.
double ConnectedColumnHeight(const ParticleArrays& particles, const Model& model,
                             const Vec3d& point, double radius, double gap, double floor);

// The values of every probe for the current state, in ProbeColumns() order.
std::vector<double> EvaluateProbes(std::span<const ProbeSpec> probes, const Model& model,
                                   const State& state);

}  // namespace dysa
