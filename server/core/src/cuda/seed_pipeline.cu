// The seed solver's passes as CUDA kernels (seed_pipeline.h says why they match the CPU bit
// for bit). Each kernel is the CPU pass of solvers/seed/seed_solver.cc with the same name; the
// comments here say only where the GPU differs in how, never in what, it computes.
#include <cuda_runtime.h>

#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_scan.cuh>
#include <stdexcept>
#include <string>
#include <utility>

#include "cuda/device_buffer.cuh"
#include "cuda/device_grid.cuh"
#include "cuda/seed_pipeline.h"

namespace dysa::cuda {
namespace {

constexpr int kLanes = 8;  // the CPU's vector width (simd.h), kept as 8 register partial sums

struct Particles {
  float *x, *y, *z;     // position, m
  float *vx, *vy, *vz;  // velocity, m/s
  float *px, *py, *pz;  // predicted position, m (after the sort: the grid's points)
  uint32_t* id;
};

struct Obstacles {
  const SphereObstacle* spheres;
  int sphere_count;
  const BoxObstacle* boxes;
  int box_count;
};

__global__ void ExternalForcesKernel(Particles p, uint32_t n, float dv, float lookahead) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  // Eigen adds the whole vector (0, dv, 0): +0 is added to x and z too (it turns -0 into +0).
  const float vx = p.vx[i] + 0.0f, vy = p.vy[i] + dv, vz = p.vz[i] + 0.0f;
  p.vx[i] = vx;
  p.vy[i] = vy;
  p.vz[i] = vz;
  p.px[i] = p.x[i] + vx * lookahead;
  p.py[i] = p.y[i] + vy * lookahead;
  p.pz[i] = p.z[i] + vz * lookahead;
}

// The unit direction of CoincidentDirection (seed_solver.cc) for two coincident particles.
__device__ void CoincidentDirection(uint32_t id_i, uint32_t id_j, float d[3]) {
  const uint32_t lo = id_i < id_j ? id_i : id_j;
  const uint32_t hi = id_i < id_j ? id_j : id_i;
  uint64_t h = (uint64_t{lo} << 32 | hi) * 0x9E3779B97F4A7C15ull;
  h ^= h >> 29;
  h *= 0xBF58476D1CE4E5B9ull;
  h ^= h >> 32;
  d[0] = float(int(h & 0xFFFF)) - 32767.5f;
  d[1] = float(int((h >> 16) & 0xFFFF)) - 32767.5f;
  d[2] = float(int((h >> 32) & 0xFFFF)) - 32767.5f;
  // Eigen's normalize(): squaredNorm as x^2 + (y^2 + z^2), then a division by its square root.
  const float n2 = d[0] * d[0] + (d[1] * d[1] + d[2] * d[2]);
  if (n2 > 0) {
    const float norm = sqrtf(n2);
    d[0] /= norm;
    d[1] /= norm;
    d[2] /= norm;
  }
  if (!(id_i < id_j)) d[0] = -d[0], d[1] = -d[1], d[2] = -d[2];
}

__device__ float LaneSum(const float v[kLanes]) {
  float s = 0;
#pragma unroll
  for (int l = 0; l < kLanes; ++l) s += v[l];
  return s;
}

template <bool kNear>
__global__ void DensityKernel(DeviceGrid grid, Particles p, float* density, float* near_density,
                              float* pressure, float* near_pressure, SeedConstants c, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const float xi = p.px[i], yi = p.py[i], zi = p.pz[i];
  float sum2[kLanes] = {}, sum3[kLanes] = {};
  grid.ForEachNeighborRun(
      grid.SortedCell(i), [&](uint32_t begin, uint32_t end, float sx, float sy, float sz) {
        const float qx = xi + sx, qy = yi + sy, qz = zi + sz;
        for (uint32_t j = begin; j < end; j += kLanes) {
#pragma unroll
          for (int l = 0; l < kLanes; ++l) {
            if (j + l >= end) break;
            const float dx = p.px[j + l] - qx, dy = p.py[j + l] - qy, dz = p.pz[j + l] - qz;
            const float r2 = dx * dx + dy * dy + dz * dz;
            if (!(r2 < c.h2)) continue;
            const float q = c.h - sqrtf(r2);
            sum2[l] += q * q;
            if (kNear) sum3[l] += q * q * q;
          }
        }
      });
  const float rho = c.mass_spiky2 * LaneSum(sum2);
  density[i] = rho;
  pressure[i] = (rho - c.rho0) * c.stiffness;
  if (kNear) {
    const float rho_near = c.mass_spiky3 * LaneSum(sum3);
    near_density[i] = rho_near;
    near_pressure[i] = rho_near * c.near_stiffness;
  }
}

// The per-neighbour factors of the pressure force (PaddedArray in the CPU pass).
__global__ void PressureFactorsKernel(const float* density, const float* pressure,
                                      const float* near_pressure, float* half_inv_rho,
                                      float* half_p_over_rho, float* half_pn_over_rho, uint32_t n,
                                      bool near) {
  const uint32_t j = blockIdx.x * blockDim.x + threadIdx.x;
  if (j >= n) return;
  half_inv_rho[j] = 0.5f / density[j];
  half_p_over_rho[j] = 0.5f * pressure[j] / density[j];
  if (near) half_pn_over_rho[j] = 0.5f * near_pressure[j] / density[j];
}

template <bool kNear>
__global__ void PressureForceKernel(DeviceGrid grid, Particles p, const float* pressure,
                                    const float* near_pressure, const float* half_inv_rho,
                                    const float* half_p_over_rho, const float* half_pn_over_rho,
                                    SeedConstants c, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const float xi = p.px[i], yi = p.py[i], zi = p.pz[i];
  const float pi = pressure[i];
  const float pni = kNear ? near_pressure[i] : 0.0f;
  float fx[kLanes] = {}, fy[kLanes] = {}, fz[kLanes] = {};
  int coincident = 0;  // candidates at distance 0, i itself included
  const int3 cell = grid.SortedCell(i);
  grid.ForEachNeighborRun(cell, [&](uint32_t begin, uint32_t end, float sx, float sy, float sz) {
    const float qx = xi + sx, qy = yi + sy, qz = zi + sz;
    for (uint32_t j = begin; j < end; j += kLanes) {
#pragma unroll
      for (int l = 0; l < kLanes; ++l) {
        if (j + l >= end) break;
        const uint32_t k = j + l;
        const float dx = p.px[k] - qx, dy = p.py[k] - qy, dz = p.pz[k] - qz;
        const float r2 = dx * dx + dy * dy + dz * dz;
        if (r2 == 0) ++coincident;
        if (!(r2 < c.h2 && r2 > 0)) continue;
        const float r = sqrtf(r2);
        const float q = c.h - r;
        const float inv_r = 1.0f / r;
        float magnitude = c.spiky2_grad * q * (pi * half_inv_rho[k] + half_p_over_rho[k]);
        if (kNear) {
          magnitude += c.spiky3_grad * q * q * (pni * half_inv_rho[k] + half_pn_over_rho[k]);
        }
        const float s = magnitude * inv_r;
        fx[l] -= dx * s;
        fy[l] -= dy * s;
        fz[l] -= dz * s;
      }
    }
  });
  float force[3] = {LaneSum(fx), LaneSum(fy), LaneSum(fz)};
  if (coincident > 1) {
    grid.ForEachNeighborRun(cell, [&](uint32_t begin, uint32_t end, float sx, float sy, float sz) {
      for (uint32_t j = begin; j < end; ++j) {
        if (j == i || p.px[j] - (xi + sx) != 0 || p.py[j] - (yi + sy) != 0 ||
            p.pz[j] - (zi + sz) != 0) {
          continue;
        }
        float magnitude = c.spiky2_grad * c.h * (pi * half_inv_rho[j] + half_p_over_rho[j]);
        if (kNear) {
          magnitude += c.spiky3_grad * c.h * c.h * (pni * half_inv_rho[j] + half_pn_over_rho[j]);
        }
        float d[3];
        CoincidentDirection(p.id[i], p.id[j], d);
        for (int a = 0; a < 3; ++a) force[a] -= d[a] * magnitude;
      }
    });
  }
  const float scale = c.mass_dt * 2 * half_inv_rho[i];
  p.vx[i] += force[0] * scale;
  p.vy[i] += force[1] * scale;
  p.vz[i] += force[2] * scale;
}

// Reads the velocities from the copy (vx0, vy0, vz0) made before the pass, as the CPU does.
__global__ void ViscosityKernel(DeviceGrid grid, Particles p, const float* vx0, const float* vy0,
                                const float* vz0, SeedConstants c, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const float xi = p.px[i], yi = p.py[i], zi = p.pz[i];
  const float vxi = vx0[i], vyi = vy0[i], vzi = vz0[i];
  float ax[kLanes] = {}, ay[kLanes] = {}, az[kLanes] = {}, wsum[kLanes] = {};
  grid.ForEachNeighborRun(grid.SortedCell(i),
                          [&](uint32_t begin, uint32_t end, float sx, float sy, float sz) {
                            const float qx = xi + sx, qy = yi + sy, qz = zi + sz;
                            for (uint32_t j = begin; j < end; j += kLanes) {
#pragma unroll
                              for (int l = 0; l < kLanes; ++l) {
                                if (j + l >= end) break;
                                const uint32_t k = j + l;
                                const float dx = p.px[k] - qx, dy = p.py[k] - qy, dz = p.pz[k] - qz;
                                const float r2 = dx * dx + dy * dy + dz * dz;
                                if (!(r2 < c.h2)) continue;
                                const float w = c.h2 - r2;
                                const float w3 = w * w * w;
                                ax[l] += (vx0[k] - vxi) * w3;
                                ay[l] += (vy0[k] - vyi) * w3;
                                az[l] += (vz0[k] - vzi) * w3;
                                wsum[l] += w3;
                              }
                            }
                          });
  const float total = LaneSum(wsum);
  const float gain = total * c.viscosity_scale > 1 ? 1 / total : c.viscosity_scale;
  p.vx[i] += LaneSum(ax) * gain;
  p.vy[i] += LaneSum(ay) * gain;
  p.vz[i] += LaneSum(az) * gain;
}

// CollideWithDomainWalls (common_passes.h) for one axis.
__device__ void CollideWithWall(float lo, float hi, bool periodic, float damping, float& x,
                                float& v) {
  if (periodic) {
    const float length = hi - lo;
    if (x >= hi) x -= length;
    if (x < lo) x += length;
    if (!(x < hi)) x = lo;
    return;
  }
  if (x <= lo) {
    x = lo;
    if (v < 0) v = -v * damping;
  } else if (x >= hi) {
    x = hi;
    if (v > 0) v = -v * damping;
  }
}

__global__ void IntegrateKernel(Particles p, SeedConstants c, GridLayout layout,
                                unsigned long long* limited, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  float v[3] = {p.vx[i], p.vy[i], p.vz[i]};
  const float speed2 = v[0] * v[0] + (v[1] * v[1] + v[2] * v[2]);
  if (speed2 > c.speed_limit * c.speed_limit) {
    const float f = c.speed_limit / sqrtf(speed2);
    v[0] *= f, v[1] *= f, v[2] *= f;
    atomicAdd(limited, 1ull);  // an integer count: the same whatever the order
  }
  float x[3] = {p.x[i] + v[0] * c.dt, p.y[i] + v[1] * c.dt, p.z[i] + v[2] * c.dt};
  for (int a = 0; a < 3; ++a) {
    CollideWithWall(c.domain_lo[a], c.domain_hi[a], layout.periodic[a], c.damping, x[a], v[a]);
  }
  p.x[i] = x[0], p.y[i] = x[1], p.z[i] = x[2];
  p.vx[i] = v[0], p.vy[i] = v[1], p.vz[i] = v[2];
}

__global__ void ObstaclesKernel(Particles p, Obstacles o, float damping, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  float x[3] = {p.x[i], p.y[i], p.z[i]};
  float v[3] = {p.vx[i], p.vy[i], p.vz[i]};
  for (int s = 0; s < o.sphere_count; ++s) {
    const SphereObstacle& sphere = o.spheres[s];
    const float r = sphere.radius;
    const float d[3] = {x[0] - sphere.center[0], x[1] - sphere.center[1], x[2] - sphere.center[2]};
    const float dist2 = d[0] * d[0] + (d[1] * d[1] + d[2] * d[2]);
    if (dist2 >= r * r) continue;
    const float dist = sqrtf(dist2);
    float nrm[3] = {0, 1, 0};
    if (dist > 0) nrm[0] = d[0] / dist, nrm[1] = d[1] / dist, nrm[2] = d[2] / dist;
    for (int a = 0; a < 3; ++a) x[a] = sphere.center[a] + nrm[a] * r;
    const float vn = v[0] * nrm[0] + (v[1] * nrm[1] + v[2] * nrm[2]);
    if (vn < 0) {
      const float k = (1 + damping) * vn;
      for (int a = 0; a < 3; ++a) v[a] -= k * nrm[a];
    }
  }
  for (int b = 0; b < o.box_count; ++b) {
    const BoxObstacle& box = o.boxes[b];
    bool inside = true;
    for (int a = 0; a < 3; ++a) inside = inside && x[a] > box.lo[a] && x[a] < box.hi[a];
    if (!inside) continue;
    int axis = 0;
    float best = x[0] - box.lo[0];
    float face = box.lo[0];
    float outward = -1;
    for (int a = 0; a < 3; ++a) {
      if (x[a] - box.lo[a] < best)
        best = x[a] - box.lo[a], axis = a, face = box.lo[a], outward = -1;
      if (box.hi[a] - x[a] < best) best = box.hi[a] - x[a], axis = a, face = box.hi[a], outward = 1;
    }
    x[axis] = face;
    if (v[axis] * outward < 0) v[axis] = -v[axis] * damping;
  }
  p.x[i] = x[0], p.y[i] = x[1], p.z[i] = x[2];
  p.vx[i] = v[0], p.vy[i] = v[1], p.vz[i] = v[2];
}

}  // namespace

struct SeedPipeline::Impl {
  explicit Impl(int device_index) : device(device_index), stream(device_index) {}

  int device;
  Stream stream;
  SeedStepConfig config;
  std::vector<std::string> passes;
  uint32_t n = 0;
  // Particle arrays and their permutation targets (swapped after each sort).
  DeviceBuffer<float> x, y, z, vx, vy, vz, px, py, pz;
  DeviceBuffer<float> x2, y2, z2, vx2, vy2, vz2, px2, py2, pz2;
  DeviceBuffer<uint32_t> id, id2;
  DeviceBuffer<float> density, near_density, pressure, near_pressure;
  DeviceBuffer<float> scratch0, scratch1, scratch2;  // the pressure factors; velocity copies
  GridSorter sorter;
  DeviceBuffer<SphereObstacle> spheres;
  DeviceBuffer<BoxObstacle> boxes;
  PinnedBuffer<unsigned long long> flags;  // [0] limited, [1] non-finite (copied back per step)
  DeviceBuffer<unsigned long long> device_flags;
  EventTimer timer;

  Particles View() {
    return {x.data(),  y.data(),  z.data(),  vx.data(), vy.data(),
            vz.data(), px.data(), py.data(), pz.data(), id.data()};
  }

  void Allocate(uint32_t count) {
    for (DeviceBuffer<float>* b : {&x,        &y,
                                   &z,        &vx,
                                   &vy,       &vz,
                                   &px,       &py,
                                   &pz,       &x2,
                                   &y2,       &z2,
                                   &vx2,      &vy2,
                                   &vz2,      &px2,
                                   &py2,      &pz2,
                                   &density,  &near_density,
                                   &pressure, &near_pressure,
                                   &scratch0, &scratch1,
                                   &scratch2}) {
      b->Resize(count);
    }
    id.Resize(count);
    id2.Resize(count);
    sorter.Reserve(count);
    n = count;
  }

  void Sort() {
    const Particles p = View();
    sorter.Sort(config.grid, p.px, p.py, p.pz, n, stream.get());
    const uint32_t* order = sorter.order();
    Gather(order, x, x2), Gather(order, y, y2), Gather(order, z, z2);
    Gather(order, vx, vx2), Gather(order, vy, vy2), Gather(order, vz, vz2);
    Gather(order, px, px2), Gather(order, py, py2), Gather(order, pz, pz2);
    Gather(order, id, id2);
  }

  template <class T>
  void Gather(const uint32_t* order, DeviceBuffer<T>& data, DeviceBuffer<T>& target) {
    GatherByOrder(order, data.data(), target.data(), n, stream.get());
    data.swap(target);
  }
};

SeedPipeline::SeedPipeline(int device) : impl_(std::make_unique<Impl>(device)) {}
SeedPipeline::~SeedPipeline() = default;

size_t SeedPipeline::size() const { return impl_->n; }

std::vector<std::string> SeedPipeline::Configure(const SeedStepConfig& config) {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  m.config = config;
  m.spheres.Assign(config.spheres, m.stream.get());
  m.boxes.Assign(config.boxes, m.stream.get());
  m.passes = {"external_forces", "neighbour_grid", "density", "pressure_force"};
  if (config.viscosity) m.passes.push_back("viscosity");
  m.passes.push_back("integrate");
  if (!config.spheres.empty() || !config.boxes.empty()) m.passes.push_back("obstacles");
  m.timer.Resize(m.passes.size() + 1);
  m.sorter.Configure(config.grid);
  m.flags.Resize(2);
  m.device_flags.Resize(2);
  CheckCuda(cudaStreamSynchronize(m.stream.get()), "configuring the seed step");
  return m.passes;
}

void SeedPipeline::Upload(size_t n, const uint32_t* id, const float* position,
                          const float* velocity) {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  if (n > uint64_t(UINT32_MAX) / 2) throw std::length_error("too many particles for the GPU");
  m.Allocate(uint32_t(n));
  UploadInterleaved(position, n, m.x, m.y, m.z, m.stream.get());
  UploadInterleaved(velocity, n, m.vx, m.vy, m.vz, m.stream.get());
  CheckCuda(cudaMemcpyAsync(m.id.data(), id, n * sizeof(uint32_t), cudaMemcpyHostToDevice,
                            m.stream.get()),
            "uploading ids");
  // Density and pressure are computed by the step; zero them so a download before the first
  // step reads zeros, as the CPU's freshly spawned arrays.
  for (DeviceBuffer<float>* b :
       {&m.px, &m.py, &m.pz, &m.density, &m.near_density, &m.pressure, &m.near_pressure}) {
    b->Zero(m.stream.get());
  }
  CheckCuda(cudaStreamSynchronize(m.stream.get()), "uploading particles");
}

void SeedPipeline::Download(uint32_t* id, float* position, float* velocity, float* predicted,
                            float* density, float* near_density, float* pressure,
                            float* near_pressure) const {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  const size_t n = m.n;
  if (id) m.id.CopyTo(id, n, m.stream.get());
  if (position) DownloadInterleaved(m.x, m.y, m.z, n, position, m.stream.get());
  if (velocity) DownloadInterleaved(m.vx, m.vy, m.vz, n, velocity, m.stream.get());
  if (predicted) DownloadInterleaved(m.px, m.py, m.pz, n, predicted, m.stream.get());
  if (density) m.density.CopyTo(density, n, m.stream.get());
  if (near_density) m.near_density.CopyTo(near_density, n, m.stream.get());
  if (pressure) m.pressure.CopyTo(pressure, n, m.stream.get());
  if (near_pressure) m.near_pressure.CopyTo(near_pressure, n, m.stream.get());
  CheckCuda(cudaStreamSynchronize(m.stream.get()), "downloading particles");
}

StepOutcome SeedPipeline::Step() {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  const SeedStepConfig& cfg = m.config;
  const SeedConstants c = cfg.constants;
  const uint32_t n = m.n;
  cudaStream_t s = m.stream.get();
  const unsigned blocks = unsigned((n + kBlock - 1) / kBlock);
  const bool launch = n > 0;
  size_t pass = 0;
  CheckCuda(cudaMemsetAsync(m.device_flags.data(), 0, 2 * sizeof(unsigned long long), s),
            "clearing the step's flags");
  auto begin_pass = [&] { m.timer.Record(pass++, s); };

  begin_pass();  // external_forces
  if (launch) {
    ExternalForcesKernel<<<blocks, kBlock, 0, s>>>(m.View(), n, cfg.gravity_dv, cfg.lookahead);
  }
  begin_pass();  // neighbour_grid
  m.Sort();
  const DeviceGrid grid = m.sorter.View();
  begin_pass();  // density
  if (launch) {
    if (cfg.near) {
      DensityKernel<true><<<blocks, kBlock, 0, s>>>(grid, m.View(), m.density.data(),
                                                    m.near_density.data(), m.pressure.data(),
                                                    m.near_pressure.data(), c, n);
    } else {
      DensityKernel<false><<<blocks, kBlock, 0, s>>>(grid, m.View(), m.density.data(),
                                                     m.near_density.data(), m.pressure.data(),
                                                     m.near_pressure.data(), c, n);
    }
  }
  begin_pass();  // pressure_force
  if (launch) {
    PressureFactorsKernel<<<blocks, kBlock, 0, s>>>(
        m.density.data(), m.pressure.data(), m.near_pressure.data(), m.scratch0.data(),
        m.scratch1.data(), m.scratch2.data(), n, cfg.near);
    if (cfg.near) {
      PressureForceKernel<true>
          <<<blocks, kBlock, 0, s>>>(grid, m.View(), m.pressure.data(), m.near_pressure.data(),
                                     m.scratch0.data(), m.scratch1.data(), m.scratch2.data(), c, n);
    } else {
      PressureForceKernel<false>
          <<<blocks, kBlock, 0, s>>>(grid, m.View(), m.pressure.data(), m.near_pressure.data(),
                                     m.scratch0.data(), m.scratch1.data(), m.scratch2.data(), c, n);
    }
  }
  if (cfg.viscosity) {
    begin_pass();  // viscosity
    if (launch) {
      m.vx.CopyToDevice(m.scratch0, n, s);
      m.vy.CopyToDevice(m.scratch1, n, s);
      m.vz.CopyToDevice(m.scratch2, n, s);
      ViscosityKernel<<<blocks, kBlock, 0, s>>>(grid, m.View(), m.scratch0.data(),
                                                m.scratch1.data(), m.scratch2.data(), c, n);
    }
  }
  begin_pass();  // integrate
  if (launch) {
    IntegrateKernel<<<blocks, kBlock, 0, s>>>(m.View(), c, cfg.grid, m.device_flags.data(), n);
  }
  if (!cfg.spheres.empty() || !cfg.boxes.empty()) {
    begin_pass();  // obstacles
    const Obstacles o{m.spheres.data(), int(cfg.spheres.size()), m.boxes.data(),
                      int(cfg.boxes.size())};
    if (launch) ObstaclesKernel<<<blocks, kBlock, 0, s>>>(m.View(), o, c.damping, n);
  }
  m.timer.Record(pass, s);
  const Particles p = m.View();
  CheckFinite(p.x, p.y, p.z, p.vx, p.vy, p.vz, n, m.device_flags.data() + 1, s);
  CheckCuda(cudaGetLastError(), "launching the seed step");
  m.flags.CopyFrom(m.device_flags, 2, s);
  CheckCuda(cudaStreamSynchronize(s), "running the seed step");

  StepOutcome outcome;
  outcome.pass_ms = m.timer.ElapsedMs(pass);
  outcome.limited = m.flags.data()[0];
  outcome.finite = m.flags.data()[1] == 0;
  return outcome;
}

uint64_t SeedPipeline::DeviceBytes() const {
  const Impl& m = *impl_;
  // 22 float arrays (positions, velocities, predictions, their permutation targets, densities,
  // pressures, scratch), two id arrays, and the grid's keys, order and cell starts.
  return uint64_t(m.x.capacity()) * (22 * sizeof(float) + 2 * sizeof(uint32_t)) +
         m.sorter.DeviceBytes();
}

}  // namespace dysa::cuda
