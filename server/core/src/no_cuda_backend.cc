// The GPU entry points of a build without CUDA (DYSA_CUDA off): every CUDA device is
// unavailable, with the reason.
#include "dysa/core/types.h"
#include "gpu_backend.h"

namespace dysa {
namespace {

constexpr const char* kNotBuilt =
    "this build has no CUDA backend (configured without DYSA_CUDA, or CMake found no CUDA "
    "compiler); rebuild on a machine with the CUDA toolkit, or run with --device cpu";

}  // namespace

bool CudaBackendBuilt() { return false; }

int CudaDeviceCount() { return 0; }

std::string DeviceUnavailableReason(const Device& device) {
  return device.is_cuda() ? kNotBuilt : "";
}

DeviceInfo QueryDevice(const Device& device) {
  if (device.is_cuda()) throw ConfigError("device", kNotBuilt);
  DeviceInfo info;
  info.name = "cpu";
  return info;
}

std::vector<std::string> GpuSolvers() { return {}; }

std::unique_ptr<GpuBackend> CreateGpuBackend(const Device& device, std::string_view) {
  QueryDevice(device);
  throw ConfigError("device", kNotBuilt);
}

}  // namespace dysa
