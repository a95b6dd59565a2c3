// Which device each rank steps on (`mpirun -np N dysa run SCENE --device ...`, `mpirun -np N
// dysa-server --device ...`): GPU ranks map to the GPUs of their host by local rank.
#pragma once

#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "dysa/core/device.h"
#include "dysa/distributed/communicator.h"

namespace dysa::distributed {

// The device of a rank given the --device text (ParseDevice's forms; ConfigError("device", ...)
// otherwise): "cuda" without an index maps the ranks of one host over its `cuda_devices` GPUs,
// cuda:(local_rank % cuda_devices) (cuda:0 when there are none, which QueryDevice then refuses
// with the reason); "cuda:N" and "cpu" as given, the same on every rank.
Device DeviceOfRank(std::string_view text, int local_rank, int cuda_devices);

// This process's rank among the ranks of its host: Open MPI's OMPI_COMM_WORLD_LOCAL_RANK
// (MPICH's MPI_LOCALRANKID, Slurm's SLURM_LOCALID where that is unset); 0 when none is set.
int LocalRank();

// Collective (every process passes a device of the same kind). Whether a process can use its
// GPU may differ between processes (another host, another ordinal), so all learn it before
// anything else is collective: throws ConfigError("device", why) on every process when any
// process's `device` cannot run (DeviceUnavailableReason; "another rank cannot use its GPU"
// where this one can). Nothing for the CPU.
void CheckRankDevicesUsable(const Communicator& comm, const Device& device);

// Collective: every process's device, by rank (each passes its own, of the same kind).
std::vector<Device> DevicesOfRanks(const Communicator& comm, const Device& device);

// For status lines: "cpu", "cuda:0" when every rank has that GPU, otherwise each rank's in rank
// order ("cuda:0 cuda:1 cuda:0"). Empty `devices`: "cpu".
std::string DescribeRankDevices(std::span<const Device> devices);

}  // namespace dysa::distributed
