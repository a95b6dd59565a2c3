// Whether a CUDA device can run, and what it is.
#include <cuda_runtime.h>

#include <string>

#include "cuda/seed_pipeline.h"

namespace dysa::cuda {

std::string ProbeCudaDevice(int index, GpuProperties* props) {
  int count = 0;
  const cudaError_t error = cudaGetDeviceCount(&count);
  if (error == cudaErrorInsufficientDriver || error == cudaErrorNoDevice || count == 0) {
    return std::string("no usable CUDA GPU on this machine (") +
           (error == cudaSuccess ? "the driver reports 0 devices" : cudaGetErrorString(error)) +
           "); run with --device cpu";
  }
  if (error != cudaSuccess) {
    return std::string("the CUDA runtime could not list the GPUs: ") + cudaGetErrorString(error);
  }
  if (index >= count) {
    return "cuda:" + std::to_string(index) + " does not exist: this machine has " +
           std::to_string(count) + " CUDA GPU" + (count == 1 ? "" : "s") + " (cuda:0" +
           (count > 1 ? " to cuda:" + std::to_string(count - 1) : std::string()) + ")";
  }
  cudaDeviceProp prop{};
  const cudaError_t query = cudaGetDeviceProperties(&prop, index);
  if (query != cudaSuccess) {
    return "cuda:" + std::to_string(index) + " could not be queried: " + cudaGetErrorString(query);
  }
  if (props) {
    props->name = prop.name;
    props->memory_bytes = prop.totalGlobalMem;
    props->compute_capability = prop.major * 10 + prop.minor;
  }
  return "";
}

int CudaDeviceCount() {
  int count = 0;
  return cudaGetDeviceCount(&count) == cudaSuccess ? count : 0;
}

}  // namespace dysa::cuda
