#include "dysa/distributed/rank_device.h"

#include <charconv>
#include <cstdlib>
#include <cstring>

namespace dysa::distributed {

Device DeviceOfRank(std::string_view text, int local_rank, int cuda_devices) {
  Device device = ParseDevice(text);
  if (text == "cuda" && cuda_devices > 0 && local_rank >= 0) {
    device.index = local_rank % cuda_devices;
  }
  return device;
}

int LocalRank() {
  for (const char* name : {"OMPI_COMM_WORLD_LOCAL_RANK", "MPI_LOCALRANKID", "SLURM_LOCALID"}) {
    const char* value = std::getenv(name);
    if (!value) continue;
    int rank = 0;
    const char* end = value + std::strlen(value);
    const auto [last, error] = std::from_chars(value, end, rank);
    if (error == std::errc() && last == end && rank >= 0) return rank;
  }
  return 0;
}

}  // namespace dysa::distributed
