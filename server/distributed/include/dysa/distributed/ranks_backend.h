// dysa::Simulation stepping on the ranks: the StepBackend of process 0 (the server's
// simulation thread), which sends every process each command through a RankRunner
// (rank_runner.h) and performs it there too. The particles live in the processes' slabs; a
// frame, a checkpoint or the status's hash gathers them to process 0 in one process's storage
// order, so that everything process 0 shows or keeps is, bit for bit, what one process's
// Simulation would have. Step back works unchanged: its checkpoints gather, its restores
// upload.
#pragma once

#include <memory>

#include "dysa/core/simulation.h"
#include "dysa/distributed/rank_runner.h"

namespace dysa::distributed {

// The factory that makes a Simulation step on `runner`'s processes (Simulation's constructor
// with a BackendFactory), on the CPU or on each process's GPU (RankRunner's devices). Each
// simulation it makes sends its scene to every process first; a scene or parameters the ranks
// cannot run (a solver other than wcsph, seed and dfsph, on CPU and GPU ranks alike; fewer grid
// layers than ranks; a scene without JSON text) are refused with a ConfigError naming the field,
// before any process is told.
Simulation::BackendFactory RanksBackendFactory(std::shared_ptr<RankRunner> runner);

// Throws ConfigError as the factory refuses: "solver", "processes" or "scene". `device`: the
// ranks' (DistributedSimulation::CheckSupported's refusals on it, as `dysa run`'s).
void CheckRunsOnRanks(const Scene& scene, const Params& params, int processes,
                      const Device& device = {});

}  // namespace dysa::distributed
