// Small RAII owners of CUDA resources (device and pinned memory, a stream, timing events) and
// the copies between the host's interleaved xyz arrays and the device's one array per axis.
#pragma once

#include <cuda_runtime.h>

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace dysa::cuda {

inline constexpr unsigned kBlock = 256;  // threads per block of the per-particle kernels

// Throws std::runtime_error naming what was being done and CUDA's reason.
inline void CheckCuda(cudaError_t error, const char* what) {
  if (error == cudaSuccess) return;
  throw std::runtime_error(std::string("CUDA error while ") + what + ": " +
                           cudaGetErrorName(error) + " (" + cudaGetErrorString(error) + ")");
}

// Makes `device` current for the scope (every call into a pipeline may come from a new thread).
class DeviceScope {
 public:
  explicit DeviceScope(int device) { CheckCuda(cudaSetDevice(device), "selecting the GPU"); }
};

class Stream {
 public:
  explicit Stream(int device) {
    DeviceScope scope(device);
    CheckCuda(cudaStreamCreateWithFlags(&stream_, cudaStreamNonBlocking), "creating a stream");
  }
  ~Stream() { cudaStreamDestroy(stream_); }
  Stream(const Stream&) = delete;
  Stream& operator=(const Stream&) = delete;
  cudaStream_t get() const { return stream_; }

 private:
  cudaStream_t stream_ = nullptr;
};

template <class T>
class DeviceBuffer {
 public:
  DeviceBuffer() = default;
  ~DeviceBuffer() { cudaFree(data_); }
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;

  // Grows to at least n elements (contents are lost when it grows); never shrinks.
  void Resize(size_t n) {
    if (n <= capacity_) return;
    cudaFree(data_);
    data_ = nullptr;
    capacity_ = 0;
    CheckCuda(cudaMalloc(reinterpret_cast<void**>(&data_), n * sizeof(T)),
              ("allocating " + std::to_string(n * sizeof(T)) + " bytes of GPU memory").c_str());
    capacity_ = n;
  }
  void Assign(const std::vector<T>& values, cudaStream_t stream) {
    Resize(values.size() > 0 ? values.size() : 1);
    if (!values.empty()) {
      CheckCuda(cudaMemcpyAsync(data_, values.data(), values.size() * sizeof(T),
                                cudaMemcpyHostToDevice, stream),
                "uploading");
      CheckCuda(cudaStreamSynchronize(stream), "uploading");
    }
  }
  void Zero(cudaStream_t stream) {
    if (capacity_ > 0)
      CheckCuda(cudaMemsetAsync(data_, 0, capacity_ * sizeof(T), stream), "zeroing");
  }
  void CopyTo(T* host, size_t n, cudaStream_t stream) const {
    if (n > 0) {
      CheckCuda(cudaMemcpyAsync(host, data_, n * sizeof(T), cudaMemcpyDeviceToHost, stream),
                "downloading");
    }
  }
  void CopyToDevice(DeviceBuffer& other, size_t n, cudaStream_t stream) const {
    if (n > 0) {
      CheckCuda(
          cudaMemcpyAsync(other.data_, data_, n * sizeof(T), cudaMemcpyDeviceToDevice, stream),
          "copying on the GPU");
    }
  }
  void swap(DeviceBuffer& other) noexcept {
    std::swap(data_, other.data_);
    std::swap(capacity_, other.capacity_);
  }
  T* data() { return data_; }
  const T* data() const { return data_; }
  size_t capacity() const { return capacity_; }

 private:
  T* data_ = nullptr;
  size_t capacity_ = 0;
};

// Page-locked host memory: device-to-host copies into it run at the bus's full speed.
template <class T>
class PinnedBuffer {
 public:
  PinnedBuffer() = default;
  ~PinnedBuffer() { cudaFreeHost(data_); }
  PinnedBuffer(const PinnedBuffer&) = delete;
  PinnedBuffer& operator=(const PinnedBuffer&) = delete;
  void Resize(size_t n) {
    if (n <= capacity_) return;
    cudaFreeHost(data_);
    data_ = nullptr;
    capacity_ = 0;
    CheckCuda(cudaMallocHost(reinterpret_cast<void**>(&data_), n * sizeof(T)),
              "allocating pinned host memory");
    capacity_ = n;
  }
  void CopyFrom(const DeviceBuffer<T>& device, size_t n, cudaStream_t stream) {
    CheckCuda(cudaMemcpyAsync(data_, device.data(), n * sizeof(T), cudaMemcpyDeviceToHost, stream),
              "downloading");
  }
  T* data() { return data_; }
  const T* data() const { return data_; }

 private:
  T* data_ = nullptr;
  size_t capacity_ = 0;
};

// Timestamps between the passes of a step: event k is recorded before pass k, the last after
// the last pass; ElapsedMs reads them once the stream has passed the last one.
class EventTimer {
 public:
  EventTimer() = default;
  ~EventTimer() {
    for (cudaEvent_t e : events_) cudaEventDestroy(e);
  }
  EventTimer(const EventTimer&) = delete;
  EventTimer& operator=(const EventTimer&) = delete;
  void Resize(size_t count) {
    while (events_.size() < count) {
      cudaEvent_t e;
      CheckCuda(cudaEventCreate(&e), "creating a timing event");
      events_.push_back(e);
    }
  }
  void Record(size_t k, cudaStream_t stream) {
    CheckCuda(cudaEventRecord(events_.at(k), stream), "recording a timing event");
  }
  // The milliseconds between events k and k + 1, for k < passes.
  std::vector<double> ElapsedMs(size_t passes) const {
    std::vector<double> ms(passes);
    for (size_t k = 0; k < passes; ++k) {
      float t = 0;
      CheckCuda(cudaEventElapsedTime(&t, events_[k], events_[k + 1]), "reading a pass timing");
      ms[k] = t;
    }
    return ms;
  }

 private:
  std::vector<cudaEvent_t> events_;
};

template <class T>
__global__ void GatherKernel(const uint32_t* order, const T* in, T* out, uint32_t n) {
  const uint32_t k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k < n) out[k] = in[order[k]];
}

// out[k] = in[order[k]]: the permutation the CPU's PermuteInPlace applies.
template <class T>
void GatherByOrder(const uint32_t* order, const T* in, T* out, uint32_t n, cudaStream_t stream) {
  if (n == 0) return;
  GatherKernel<<<(n + kBlock - 1) / kBlock, kBlock, 0, stream>>>(order, in, out, n);
}

static __global__ void SplitKernel(const float* xyz, float* x, float* y, float* z, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  x[i] = xyz[3 * size_t(i)];
  y[i] = xyz[3 * size_t(i) + 1];
  z[i] = xyz[3 * size_t(i) + 2];
}

static __global__ void InterleaveKernel(const float* x, const float* y, const float* z, float* xyz,
                                        uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  xyz[3 * size_t(i)] = x[i];
  xyz[3 * size_t(i) + 1] = y[i];
  xyz[3 * size_t(i) + 2] = z[i];
}

// n host xyz triples into three device arrays (through a temporary device buffer).
inline void UploadInterleaved(const float* host_xyz, size_t n, DeviceBuffer<float>& x,
                              DeviceBuffer<float>& y, DeviceBuffer<float>& z, cudaStream_t stream) {
  if (n == 0) return;
  DeviceBuffer<float> staging;
  staging.Resize(3 * n);
  CheckCuda(cudaMemcpyAsync(staging.data(), host_xyz, 3 * n * sizeof(float), cudaMemcpyHostToDevice,
                            stream),
            "uploading particles");
  SplitKernel<<<unsigned((n + kBlock - 1) / kBlock), kBlock, 0, stream>>>(
      staging.data(), x.data(), y.data(), z.data(), uint32_t(n));
  CheckCuda(cudaStreamSynchronize(stream), "uploading particles");
}

inline void DownloadInterleaved(const DeviceBuffer<float>& x, const DeviceBuffer<float>& y,
                                const DeviceBuffer<float>& z, size_t n, float* host_xyz,
                                cudaStream_t stream) {
  if (n == 0) return;
  DeviceBuffer<float> staging;
  staging.Resize(3 * n);
  InterleaveKernel<<<unsigned((n + kBlock - 1) / kBlock), kBlock, 0, stream>>>(
      x.data(), y.data(), z.data(), staging.data(), uint32_t(n));
  CheckCuda(cudaMemcpyAsync(host_xyz, staging.data(), 3 * n * sizeof(float), cudaMemcpyDeviceToHost,
                            stream),
            "downloading particles");
  CheckCuda(cudaStreamSynchronize(stream), "downloading particles");
}

// out[3 id[i] + a] = (x, y, z)[a][i], or out[id[i]] = x[i] when y and z are null.
template <class Unused = void>
__global__ void ScatterByIdKernel(const uint32_t* id, const float* x, const float* y,
                                  const float* z, float* out, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const size_t k = id[i];
  if (y == nullptr) {
    out[k] = x[i];
    return;
  }
  out[3 * k] = x[i];
  out[3 * k + 1] = y[i];
  out[3 * k + 2] = z[i];
}

// Copies n values (y, z null) or xyz triples to `host` in particle-id order, through `staging`
// (kept by the caller, so a frame allocates nothing on the GPU). Returns once they are there.
inline void DownloadById(const uint32_t* id, const float* x, const float* y, const float* z,
                         size_t n, float* host, DeviceBuffer<float>& staging, cudaStream_t stream) {
  if (n == 0) return;
  const size_t count = y ? 3 * n : n;
  staging.Resize(count);
  ScatterByIdKernel<<<unsigned((n + kBlock - 1) / kBlock), kBlock, 0, stream>>>(
      id, x, y, z, staging.data(), uint32_t(n));
  CheckCuda(
      cudaMemcpyAsync(host, staging.data(), count * sizeof(float), cudaMemcpyDeviceToHost, stream),
      "downloading a frame");
  CheckCuda(cudaStreamSynchronize(stream), "downloading a frame");
}

// flag stays 0 while every value is finite (x - x is NaN exactly when x is not finite).
static __global__ void FiniteKernel(const float* a, const float* b, const float* c, const float* d,
                                    const float* e, const float* f, uint32_t n,
                                    unsigned long long* flag) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const float sum =
      (a[i] - a[i]) + (b[i] - b[i]) + (c[i] - c[i]) + (d[i] - d[i]) + (e[i] - e[i]) + (f[i] - f[i]);
  if (!(sum == 0)) *flag = 1;  // every writer writes the same value
}

inline void CheckFinite(const float* x, const float* y, const float* z, const float* vx,
                        const float* vy, const float* vz, uint32_t n, unsigned long long* flag,
                        cudaStream_t stream) {
  if (n == 0) return;
  FiniteKernel<<<(n + kBlock - 1) / kBlock, kBlock, 0, stream>>>(x, y, z, vx, vy, vz, n, flag);
}

}  // namespace dysa::cuda
