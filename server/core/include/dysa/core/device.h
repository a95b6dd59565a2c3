// Where a simulation's step runs: the CPU (OpenMP) or a CUDA GPU.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace dysa {

struct Device {
  enum class Kind { kCpu, kCuda };
  Kind kind = Kind::kCpu;
  int index = 0;  // the CUDA device ordinal (cuda:N); 0 for the CPU

  bool is_cuda() const { return kind == Kind::kCuda; }
  // "cpu", "cuda:0", ...: the text ParseDevice reads back.
  std::string ToString() const;
};

// Reads "cpu", "cuda" (= cuda:0) or "cuda:N" (N in [0, 63]). Throws ConfigError("device", ...)
// naming the accepted forms.
Device ParseDevice(std::string_view text);

// What a device is, for status lines and GetStatus.
struct DeviceInfo {
  std::string name;                                  // "cpu", or the GPU's model ("NVIDIA H200")
  uint64_t memory_bytes = 0;                         // the GPU's global memory; 0 for the CPU
  int compute_capability = 0;                        // major * 10 + minor; 0 for the CPU
  std::string Describe(const Device& device) const;  // "cuda:0 NVIDIA H200, 139.8 GiB, sm_90"
};

// True when this build has the CUDA backend (DYSA_CUDA); a GPU may still be missing.
bool CudaBackendBuilt();

// Empty when `device` can run a step now; otherwise why not, naming what is missing (a build
// without CUDA, no driver, no GPU, an ordinal past the GPUs present). Never throws.
std::string DeviceUnavailableReason(const Device& device);

// The CUDA GPUs this process can use; 0 without CUDA (the build, the driver or a GPU). Never
// throws.
int CudaDeviceCount();

// The device's name and memory. Throws ConfigError("device", DeviceUnavailableReason(...)) when
// it cannot run.
DeviceInfo QueryDevice(const Device& device);

}  // namespace dysa
