// `mpirun -np N dysa run SCENE`: the offline run spread over the processes of a Communicator
// (server/distributed). With SingleProcess it runs on one process, the same way.
#pragma once

#include <iosfwd>
#include <stdexcept>

#include "dysa/distributed/communicator.h"
#include "run_command.h"

namespace dysa {

// An error every rank raises together, so that each can exit without waiting for the others:
// rank 0 cannot write the output directory.
class CollectiveError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Runs options.scene across comm's processes with the steps, probe rows and VTK frames of
// RunOffline, written by process 0 from the particles of all (gathered in the storage order of
// one process, so probes.csv and the frames are byte-identical to RunOffline's), and prints on
// process 0 the per-pass times (the slowest process's), the throughput, the decomposition and
// what it exchanged, and with options.print_hash the state hash. With a CUDA options.device
// each rank steps on its GPU (DistributedSimulation; the caller chooses each rank's, as
// distributed::DeviceOfRank). Throws ConfigError as RunOffline and DistributedSimulation (what
// GPU ranks cannot run by field; "device" when a rank cannot use its GPU, on every rank),
// CollectiveError when the output cannot be written.
void RunDistributed(const RunOptions& options, const distributed::Communicator& comm,
                    std::ostream& out);

}  // namespace dysa
