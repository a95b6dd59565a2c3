// The CUDA backends of the solvers (built with DYSA_CUDA): the device queries and the backend
// for a solver. The backends: seed_gpu_backend.cc, wcsph_gpu_backend.cc, dfsph_gpu_backend.cc,
// over what pipeline_backend.h shares.
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "cuda/pipeline_backend.h"
#include "gpu_backend.h"

namespace dysa {
namespace cuda {
// The CUDA GPUs this process sees; 0 when the runtime lists none (cuda_probe.cu).
int CudaDeviceCount();
}  // namespace cuda

bool CudaBackendBuilt() { return true; }

int CudaDeviceCount() { return cuda::CudaDeviceCount(); }

std::string DeviceUnavailableReason(const Device& device) {
  if (!device.is_cuda()) return "";
  return cuda::ProbeCudaDevice(device.index, nullptr);
}

DeviceInfo QueryDevice(const Device& device) {
  DeviceInfo info;
  if (!device.is_cuda()) {
    info.name = "cpu";
    return info;
  }
  cuda::GpuProperties props;
  const std::string reason = cuda::ProbeCudaDevice(device.index, &props);
  if (!reason.empty()) throw ConfigError("device", reason);
  info.name = props.name;
  info.memory_bytes = props.memory_bytes;
  info.compute_capability = props.compute_capability;
  return info;
}

std::vector<std::string> GpuSolvers() { return {"seed", "wcsph", "dfsph"}; }

std::unique_ptr<GpuBackend> CreateGpuBackend(const Device& device, std::string_view solver) {
  const DeviceInfo info = QueryDevice(device);  // throws, naming what is missing
  if (solver == "seed") return cuda_backend::MakeSeedGpuBackend(device, info);
  if (solver == "wcsph") return cuda_backend::MakeWcsphGpuBackend(device, info);
  if (solver == "dfsph") return cuda_backend::MakeDfsphGpuBackend(device, info);
  throw ConfigError("device", "the solver \"" + std::string(solver) +
                                  "\" has no CUDA backend (GPU solvers: seed, wcsph, dfsph); "
                                  "run it with --device cpu");
}

}  // namespace dysa
