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

// The values of every probe for the current state, in ProbeColumns() order.
std::vector<double> EvaluateProbes(std::span<const ProbeSpec> probes, const Model& model,
                                   const State& state);

}  // namespace dysa
