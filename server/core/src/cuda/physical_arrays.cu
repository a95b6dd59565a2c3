// The physical solvers' shared arrays (physical_arrays.cuh).
#include <cuda_runtime.h>

#include "cuda/physical_arrays.cuh"

namespace dysa::cuda {

void PhysicalArrays::AllocateFluid(size_t count, std::initializer_list<DeviceBuffer<float>*> own) {
  const size_t elements = count > 0 ? count : 1;
  AllocateParticles(count, elements, own);
  for (DeviceBuffer<float>* b : {&ax, &ay, &az, &speed2, &acceleration2}) b->Resize(elements);
}

void PhysicalArrays::ConfigureArrays(const GridLayout& grid,
                                     const std::vector<SphereObstacle>& sphere_list,
                                     const std::vector<BoxObstacle>& box_list,
                                     const BoundaryCloud& boundary,
                                     std::initializer_list<DeviceBuffer<float>*> own) {
  cudaStream_t s = stream.get();
  spheres.Assign(sphere_list, s);
  boxes.Assign(box_list, s);
  sphere_count = int(sphere_list.size());
  box_count = int(box_list.size());
  for (int a = 0; a < 3; ++a) periodic[a] = grid.periodic[a];
  sorter.Configure(grid);
  boundary_sorter.Configure(grid);
  // The boundary, sorted on its own grid (already in cell order: the stable sort keeps it).
  nb = uint32_t(boundary.volume.size());
  const uint32_t elements = nb > 0 ? nb : 1;
  for (DeviceBuffer<float>* b : {&bx, &by, &bz, &bvolume, &bvx, &bvy, &bvz}) {
    b->Resize(elements);
    b->Zero(s);
  }
  for (DeviceBuffer<float>* b : own) {
    b->Resize(elements);
    b->Zero(s);
  }
  bno_slip.Resize(elements);
  bx.Assign(boundary.x, s), by.Assign(boundary.y, s), bz.Assign(boundary.z, s);
  bvolume.Assign(boundary.volume, s);
  bno_slip.Assign(boundary.no_slip, s);
  boundary_sorter.Reserve(nb);
  boundary_sorter.Sort(grid, bx.data(), by.data(), bz.data(), nb, s);
  if (nb > 0) {
    // The identity permutation when the host's order is the grid's, as it is; applied anyway so
    // that the arrays always match the cell starts.
    const uint32_t* order = boundary_sorter.order();
    DeviceBuffer<float> scratch;
    scratch.Resize(nb);
    for (DeviceBuffer<float>* b : {&bx, &by, &bz, &bvolume}) Gather(order, *b, scratch, nb);
    DeviceBuffer<uint8_t> flags;
    flags.Resize(nb);
    Gather(order, bno_slip, flags, nb);
  }
  moving.Configure(boundary, s);
  obstacle_speed = 0;
}

void PhysicalArrays::MoveSurfaces(const std::vector<SphereObstacle>& sphere_list,
                                  const std::vector<BoxObstacle>& box_list, float speed) {
  DeviceScope scope(device);
  spheres.Assign(sphere_list, stream.get());
  boxes.Assign(box_list, stream.get());
  obstacle_speed = speed;
}

void PhysicalArrays::MoveBoundary(const GridLayout& grid, const ObstacleMotionTable& motion) {
  moving.Move(motion.offset, motion.velocity, grid, boundary_sorter, bx.data(), by.data(),
              bz.data(), bvolume.data(), bno_slip.data(), stream.get());
}

const uint32_t* PhysicalArrays::SortFluid(const GridLayout& grid) {
  sorter.Sort(grid, x.data(), y.data(), z.data(), n, stream.get());
  const uint32_t* order = sorter.order();
  if (n > 0) {
    Gather(order, x, x2, n), Gather(order, y, y2, n), Gather(order, z, z2, n);
    Gather(order, vx, vx2, n), Gather(order, vy, vy2, n);
    Gather(order, vz, vz2, n), Gather(order, id, id2, n);
  }
  return order;
}

uint64_t PhysicalArrays::PhysicalDeviceBytes() const {
  // 5 more float arrays per particle; 7 float arrays and the flags per boundary sample.
  return ParticleDeviceBytes() + uint64_t(x.capacity()) * 5 * sizeof(float) +
         uint64_t(bx.capacity()) * (7 * sizeof(float) + 1) + boundary_sorter.DeviceBytes() +
         moving.DeviceBytes();
}

}  // namespace dysa::cuda
