// `mpirun -np N dysa run SCENE`: the offline run spread over the processes of a Communicator
// (server/distributed). Without a communicator of MPI it runs on one process, the same way.
#pragma once

#include <iosfwd>

#include "dysa/distributed/communicator.h"
#include "run_command.h"

namespace dysa {

// Runs options.scene across comm's processes, stepping to the same times as RunOffline (whose
// steps are capped at each probe row), and prints on process 0 the per-pass times (the slowest
// process's), the throughput, the decomposition and what it exchanged, and with
// options.print_hash the state hash (the value RunOffline prints for the same run). Writes no
// probes or frames: throws std::invalid_argument naming --vtk-every or --device for what does
// not run across processes yet, ConfigError as RunOffline and DistributedSimulation.
void RunDistributed(const RunOptions& options, const distributed::Communicator& comm,
                    std::ostream& out);

}  // namespace dysa
