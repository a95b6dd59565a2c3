// The moving obstacles' boundary samples on the GPU, for the physical solvers' move_boundary
// pass (BoundaryParticles::MoveObstacles): each step every sample is placed at its rest
// position plus its obstacle's displacement, the samples are sorted on the boundary's grid again
// (the stable sort of device_grid.cuh, so in the CPU's order) and their volumes, no-slip flags
// and obstacle velocities follow them. Only a scene with a moving obstacle configures it; a
// static scene's boundary stays as Configure sorted it.
#pragma once

#include <cuda_runtime.h>

#include <cstdint>
#include <vector>

#include "cuda/device_buffer.cuh"
#include "cuda/device_grid.cuh"
#include "cuda/gpu_types.h"
#include "cuda/wcsph_pipeline.h"  // BoundaryCloud

namespace dysa::cuda {
namespace moving_boundary {
// Each file that includes this gets its own copy of these kernels.
namespace {

// x = rest + offset[o] in float, the same sum for every sample of an obstacle (a rigid move).
__global__ void PlaceSamplesKernel(const float* rx, const float* ry, const float* rz,
                                   const int32_t* obstacle, const float* offset, float* x, float* y,
                                   float* z, uint32_t n) {
  const uint32_t k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k >= n) return;
  const int32_t o = obstacle[k];
  x[k] = o < 0 ? rx[k] : rx[k] + offset[3 * o];
  y[k] = o < 0 ? ry[k] : ry[k] + offset[3 * o + 1];
  z[k] = o < 0 ? rz[k] : rz[k] + offset[3 * o + 2];
}

// The velocity of sorted sample k: its obstacle's, 0 for a domain wall.
__global__ void SampleVelocityKernel(const uint32_t* order, const int32_t* obstacle,
                                     const float* velocity, float* ux, float* uy, float* uz,
                                     uint32_t n) {
  const uint32_t k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k >= n) return;
  const int32_t o = obstacle[order[k]];
  ux[k] = o < 0 ? 0.0f : velocity[3 * o];
  uy[k] = o < 0 ? 0.0f : velocity[3 * o + 1];
  uz[k] = o < 0 ? 0.0f : velocity[3 * o + 2];
}

}  // namespace
}  // namespace moving_boundary

class MovingBoundary {
 public:
  // Keeps the samples' rest arrays when `cloud` has them (some obstacle moves); otherwise
  // inactive, holding nothing.
  void Configure(const BoundaryCloud& cloud, cudaStream_t stream) {
    n_ = uint32_t(cloud.obstacle.size());
    active_ = n_ > 0;
    if (!active_) return;
    rest_x_.Assign(cloud.rest_x, stream), rest_y_.Assign(cloud.rest_y, stream);
    rest_z_.Assign(cloud.rest_z, stream);
    rest_volume_.Assign(cloud.rest_volume, stream);
    rest_no_slip_.Assign(cloud.rest_no_slip, stream);
    obstacle_.Assign(cloud.obstacle, stream);
    for (DeviceBuffer<float>* b : {&x_, &y_, &z_, &ux_, &uy_, &uz_}) b->Resize(n_);
  }

  bool active() const { return active_; }

  // Places the samples for obstacles displaced by offset and moving at velocity (3 floats per
  // obstacle, boxes then spheres), sorts them with `sorter` on `layout` and writes the sorted
  // positions, volumes and flags into the pipeline's boundary arrays.
  void Move(const std::vector<float>& offset, const std::vector<float>& velocity,
            const GridLayout& layout, GridSorter& sorter, float* x, float* y, float* z,
            float* volume, uint8_t* no_slip, cudaStream_t stream) {
    offset_.Assign(offset, stream);
    velocity_.Assign(velocity, stream);
    const unsigned blocks = (n_ + kBlock - 1) / kBlock;
    moving_boundary::PlaceSamplesKernel<<<blocks, kBlock, 0, stream>>>(
        rest_x_.data(), rest_y_.data(), rest_z_.data(), obstacle_.data(), offset_.data(), x_.data(),
        y_.data(), z_.data(), n_);
    sorter.Sort(layout, x_.data(), y_.data(), z_.data(), n_, stream);
    const uint32_t* order = sorter.order();
    GatherByOrder(order, x_.data(), x, n_, stream);
    GatherByOrder(order, y_.data(), y, n_, stream);
    GatherByOrder(order, z_.data(), z, n_, stream);
    GatherByOrder(order, rest_volume_.data(), volume, n_, stream);
    GatherByOrder(order, rest_no_slip_.data(), no_slip, n_, stream);
    moving_boundary::SampleVelocityKernel<<<blocks, kBlock, 0, stream>>>(
        order, obstacle_.data(), velocity_.data(), ux_.data(), uy_.data(), uz_.data(), n_);
  }

  // m/s, per sample in grid order: its obstacle's velocity; null when inactive.
  const float* ux() const { return active_ ? ux_.data() : nullptr; }
  const float* uy() const { return active_ ? uy_.data() : nullptr; }
  const float* uz() const { return active_ ? uz_.data() : nullptr; }

  uint64_t DeviceBytes() const {
    return active_ ? uint64_t(n_) * (10 * sizeof(float) + sizeof(int32_t) + 1) : 0;
  }

 private:
  bool active_ = false;
  uint32_t n_ = 0;
  DeviceBuffer<float> rest_x_, rest_y_, rest_z_, rest_volume_, x_, y_, z_, ux_, uy_, uz_;
  DeviceBuffer<uint8_t> rest_no_slip_;
  DeviceBuffer<int32_t> obstacle_;
  DeviceBuffer<float> offset_, velocity_;
};

}  // namespace dysa::cuda
