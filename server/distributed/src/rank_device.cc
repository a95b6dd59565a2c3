#include "dysa/distributed/rank_device.h"

#include <algorithm>
#include <charconv>
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "dysa/core/types.h"

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

void CheckRankDevicesUsable(const Communicator& comm, const Device& device) {
  if (!device.is_cuda()) return;
  const std::string reason = DeviceUnavailableReason(device);
  double unusable = reason.empty() ? 0 : 1;
  comm.MaxInPlace({&unusable, 1});
  if (unusable > 0) {
    throw ConfigError("device", reason.empty() ? "another rank cannot use its GPU" : reason);
  }
}

std::vector<Device> DevicesOfRanks(const Communicator& comm, const Device& device) {
  std::vector<int64_t> index(size_t(comm.size()), 0);
  index[size_t(comm.rank())] = device.index;
  comm.SumInPlace(index);
  std::vector<Device> devices(index.size(), device);
  for (size_t r = 0; r < index.size(); ++r) devices[r].index = int(index[r]);
  return devices;
}

std::string DescribeRankDevices(std::span<const Device> devices) {
  if (devices.empty()) return "cpu";
  const bool same = std::all_of(devices.begin(), devices.end(), [&](const Device& d) {
    return d.kind == devices[0].kind && d.index == devices[0].index;
  });
  if (same) return devices[0].ToString();
  std::string text;
  for (const Device& d : devices) text += (text.empty() ? "" : " ") + d.ToString();
  return text;
}

}  // namespace dysa::distributed
