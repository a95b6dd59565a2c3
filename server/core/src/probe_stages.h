// The stages of probe evaluation (probe_gather.h): the plan, the CPU's gather and the finish.
#pragma once

#include <span>
#include <vector>

#include "dysa/core/model.h"
#include "dysa/core/scene.h"
#include "dysa/core/state.h"
#include "probe_gather.h"

namespace dysa {

// What the gather must collect for `probes`: a window per local probe, wide enough to hold every
// particle its finish can weigh (the kernel's support around a pressure probe, the column's
// radius around a height probe, over the whole height), and the reductions the others need.
ProbeGatherPlan PlanProbeGather(std::span<const ProbeSpec> probes, const Model& model);

// The gather on the CPU, over the host's particle arrays (in parallel, chunk by chunk).
void GatherProbes(const ProbeGatherPlan& plan, const ParticleArrays& particles, ProbeGather& out);

// The values of every probe (ProbeColumns() order) from a gather made with
// PlanProbeGather(probes, model); `time` (s) is the state's, for the gravity a wall pressure
// probe's hydrostatic correction uses.
std::vector<double> FinishProbes(std::span<const ProbeSpec> probes, const Model& model, double time,
                                 const ProbeGather& gather);

}  // namespace dysa
