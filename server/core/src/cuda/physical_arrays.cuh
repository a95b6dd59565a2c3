// The physical solvers' (wcsph, dfsph) shared state on the GPU: the particle arrays
// (particle_buffers.cuh) with the accelerations and the time step's maxima inputs, the boundary
// particles sorted on their own grid (and moved by the move_boundary pass), and the obstacles
// of the wall contact. Both pipelines set these up, sort and move them the same way; each keeps
// only its solver's arrays beside them (sph_kernels.cuh's FluidOf, BoundaryOf and SurfacesOf
// make the kernels' views of both).
#pragma once

#include <cuda_runtime.h>

#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <vector>

#include "cuda/device_buffer.cuh"
#include "cuda/device_grid.cuh"
#include "cuda/gpu_types.h"
#include "cuda/moving_boundary.cuh"
#include "cuda/particle_buffers.cuh"
#include "cuda/wcsph_pipeline.h"  // BoundaryCloud

namespace dysa::cuda {

struct PhysicalArrays : ParticleBuffers {
  explicit PhysicalArrays(int device_index) : ParticleBuffers(device_index) {}

  // AllocateParticles with these arrays and the pipeline's `own`, at least one value each (the
  // kernels' views hold no null arrays).
  void AllocateFluid(size_t count, std::initializer_list<DeviceBuffer<float>*> own);

  // Keeps the obstacles, configures both sorters for `grid` and uploads the boundary, sorted on
  // its grid; `own` are the pipeline's per-sample arrays, sized and zeroed with the boundary's.
  void ConfigureArrays(const GridLayout& grid, const std::vector<SphereObstacle>& sphere_list,
                       const std::vector<BoxObstacle>& box_list, const BoundaryCloud& boundary,
                       std::initializer_list<DeviceBuffer<float>*> own);

  // The contact's obstacles (the configuration's count and order) over the coming integration.
  void MoveSurfaces(const std::vector<SphereObstacle>& sphere_list,
                    const std::vector<BoxObstacle>& box_list, float speed);

  // The move_boundary pass's work: the moving obstacles' samples placed for `motion`.
  void MoveBoundary(const GridLayout& grid, const ObstacleMotionTable& motion);

  // The neighbour_grid pass's sort of the fluid on `grid`, with the positions, velocities and
  // ids permuted; returns the order, with which the pipeline permutes its own arrays (n > 0).
  const uint32_t* SortFluid(const GridLayout& grid);

  // Bytes of these arrays, the sorters and the moving boundary's (ParticleDeviceBytes included).
  uint64_t PhysicalDeviceBytes() const;

  DeviceBuffer<float> ax, ay, az, speed2, acceleration2;
  // The boundary: positions, volumes and no-slip flags in its grid's order, its grid, and the
  // no-slip walls' extrapolated velocities.
  uint32_t nb = 0;
  DeviceBuffer<float> bx, by, bz, bvolume, bvx, bvy, bvz;
  DeviceBuffer<uint8_t> bno_slip;
  GridSorter boundary_sorter;
  MovingBoundary moving;
  // The wall contact's obstacles; periodic axes have no walls.
  DeviceBuffer<SphereObstacle> spheres;
  DeviceBuffer<BoxObstacle> boxes;
  int sphere_count = 0, box_count = 0;
  bool periodic[3] = {false, false, false};
  float obstacle_speed = 0;  // m/s, the contact's fastest obstacle (MoveSurfaces)
};

}  // namespace dysa::cuda
