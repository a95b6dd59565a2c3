// Which device each rank steps on (`mpirun -np N dysa run SCENE --device ...`): GPU ranks map to
// the GPUs of their host by local rank.
#pragma once

#include <string_view>

#include "dysa/core/device.h"

namespace dysa::distributed {

// The device of a rank given the --device text (ParseDevice's forms; ConfigError("device", ...)
// otherwise): "cuda" without an index maps the ranks of one host over its `cuda_devices` GPUs,
// cuda:(local_rank % cuda_devices) (cuda:0 when there are none, which QueryDevice then refuses
// with the reason); "cuda:N" and "cpu" as given, the same on every rank.
Device DeviceOfRank(std::string_view text, int local_rank, int cuda_devices);

// This process's rank among the ranks of its host: Open MPI's OMPI_COMM_WORLD_LOCAL_RANK
// (MPICH's MPI_LOCALRANKID, Slurm's SLURM_LOCALID where that is unset); 0 when none is set.
int LocalRank();

}  // namespace dysa::distributed
