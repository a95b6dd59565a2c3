// The dfsph solver's passes as CUDA kernels, each the CPU code of
// solvers/dfsph/bender_koschier_solver.cc and pressure_boundary.cc with the same name and the
// same operations in the same order (dfsph_pipeline.h says where the GPU differs).
#include <cuda_runtime.h>

#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_reduce.cuh>
#include <cub/device/device_scan.cuh>
#include <stdexcept>
#include <string>

#include "cuda/device_buffer.cuh"
#include "cuda/device_grid.cuh"
#include "cuda/dfsph_pipeline.h"
#include "cuda/fixed_point_sum.cuh"
#include "cuda/moving_boundary.cuh"
#include "cuda/probe_gatherer.cuh"
#include "cuda/rank_subset.cuh"
#include "cuda/sph_kernels.cuh"
#include "cuda/view_subset.cuh"

namespace dysa::cuda {
namespace {

using namespace sph;  // NOLINT: the shared half of these kernels

// The largest density error, as a fraction of rho0, one iteration of the density solve
// corrects (kMaxCorrection in bender_koschier_solver.cc).
constexpr float kMaxCorrection = 0.05f;

// m, the domain's length along each periodic axis, 0 along the others (Model::MinimumImage).
struct Periods {
  float length[3];
};

// A pair of the density pass: the other particle and grad W (1/m^4).
struct Pair {
  uint32_t other;
  float gx, gy, gz;
};

// The per-particle arrays of the solves (Work in bender_koschier_solver.cc) and the lists.
struct Solver {
  float *alpha, *kappa, *error, *kappa_sum;
  const uint32_t *fluid_begin, *wall_begin;
  Pair *fluid_pairs, *wall_pairs;
  // The walls' fluid neighbours (dfsph::BoundaryNeighbors), b's in [bn_begin[b], bn_begin[b+1]).
  const uint32_t* bn_begin;
  const uint32_t* bn_fluid;
  float* bn_weight;
  float* hydrostatic;  // Pa
  float* kappa_b;      // kappa_b / rho of the current iteration
};

// The counts of pairs at distance > 0 within the support, fluid and wall, of each particle.
__global__ void CountPairsKernel(DeviceGrid grid, DeviceGrid bgrid, Fluid f, Boundary b,
                                 SphConstants c, uint32_t* fluid_count, uint32_t* wall_count,
                                 uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const int3 cell = grid.SortedCell(i);
  const F3 x{f.x[i], f.y[i], f.z[i]};
  uint32_t fluid = 0, wall = 0;
  ForEachWithin(grid, {f.x, f.y, f.z}, cell, x, c.support, [&](uint32_t, F3, float r) {
    if (r > 0) ++fluid;
  });
  ForEachWithin(bgrid, {b.x, b.y, b.z}, cell, x, c.support, [&](uint32_t, F3, float r) {
    if (r > 0) ++wall;
  });
  fluid_count[i] = fluid;
  wall_count[i] = wall;
}

// DensityAndFactor: rho_i, alpha_i and the pairs.
__global__ void DensityAndFactorKernel(DeviceGrid grid, DeviceGrid bgrid, Fluid f, Boundary b,
                                       Solver s, SphConstants c, uint32_t* wall_owner, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const int3 cell = grid.SortedCell(i);
  const F3 x{f.x[i], f.y[i], f.z[i]};
  const float rho0 = c.psi_scale;
  float fluid = 0, squares = 0;
  F3 grad{0, 0, 0};
  uint32_t k = s.fluid_begin[i];
  ForEachWithin(grid, {f.x, f.y, f.z}, cell, x, c.support, [&](uint32_t j, F3 xij, float r) {
    fluid += KernelW(r, c);
    const float gf = GradFactor(r, c);
    const F3 g{xij.x * gf, xij.y * gf, xij.z * gf};
    if (r > 0) s.fluid_pairs[k++] = Pair{j, g.x, g.y, g.z};
    const F3 mg{c.mass * g.x, c.mass * g.y, c.mass * g.z};
    grad.x += mg.x, grad.y += mg.y, grad.z += mg.z;
    squares += Norm2(mg);
  });
  float wall = 0;
  uint32_t kw = s.wall_begin[i];
  ForEachWithin(bgrid, {b.x, b.y, b.z}, cell, x, c.support, [&](uint32_t o, F3 xib, float r) {
    wall += b.volume[o] * KernelW(r, c);
    const float gf = GradFactor(r, c);
    const F3 g{xib.x * gf, xib.y * gf, xib.z * gf};
    if (r > 0) {
      wall_owner[kw] = i;
      s.wall_pairs[kw++] = Pair{o, g.x, g.y, g.z};
    }
    const float psi = rho0 * b.volume[o];
    grad.x += psi * g.x, grad.y += psi * g.y, grad.z += psi * g.z;
  });
  const float rho = (c.mass * fluid + rho0 * wall) * c.density_scale;
  f.density[i] = rho;
  const float denominator = Norm2(grad) + squares;
  s.alpha[i] = denominator > 1e-6f * rho * rho / (c.support * c.support) ? rho / denominator : 0.0f;
}

// The walls' Shepard weights and hydrostatic pressure (ListBoundaryNeighbors).
__global__ void BoundaryWeightsKernel(Fluid f, Boundary b, Solver s, SphConstants c, Periods period,
                                      float gravity) {
  const uint32_t o = blockIdx.x * blockDim.x + threadIdx.x;
  if (o >= b.n) return;
  float sum = 0, head = 0;
  for (uint32_t k = s.bn_begin[o]; k < s.bn_begin[o + 1]; ++k) {
    const uint32_t i = s.bn_fluid[k];
    float d[3] = {b.x[o] - f.x[i], b.y[o] - f.y[i], b.z[o] - f.z[i]};
    for (int a = 0; a < 3; ++a) {  // Model::MinimumImage
      const float length = period.length[a];
      if (length == 0) continue;
      if (d[a] > length / 2) d[a] -= length;
      if (d[a] < -length / 2) d[a] += length;
    }
    const float w = KernelW(sqrtf(Norm2({d[0], d[1], d[2]})), c);
    s.bn_weight[k] = w;
    sum += w;
    head += w * f.density[i] * d[1];
  }
  const float inv = sum > 0 ? 1 / sum : 0.0f;
  for (uint32_t k = s.bn_begin[o]; k < s.bn_begin[o + 1]; ++k) s.bn_weight[k] *= inv;
  const float hydrostatic = gravity * head * inv;
  s.hydrostatic[o] = hydrostatic < 0.0f ? 0.0f : hydrostatic;  // std::max(., 0)
  s.kappa_b[o] = 0;
}

__global__ void HydrostaticAccelerationKernel(Fluid f, Boundary b, Solver s, SphConstants c,
                                              float mu, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  F3 sum{0, 0, 0};
  for (uint32_t k = s.wall_begin[i]; k < s.wall_begin[i + 1]; ++k) {
    const Pair p = s.wall_pairs[k];
    const float w = b.volume[p.other] * s.hydrostatic[p.other];
    sum.x += w * p.gx, sum.y += w * p.gy, sum.z += w * p.gz;
  }
  const float rho = f.density[i];
  const float scale = -c.psi_scale / (rho * rho * mu);
  f.ax[i] = scale * sum.x, f.ay[i] = scale * sum.y, f.az[i] = scale * sum.z;
}

// D rho_i / Dt over the step's pairs (DensityRate).
__device__ float DensityRate(const Fluid& f, const Boundary& b, const Solver& s,
                             const SphConstants& c, uint32_t i) {
  const F3 v{f.vx[i], f.vy[i], f.vz[i]};
  float rate = 0;
  for (uint32_t k = s.fluid_begin[i]; k < s.fluid_begin[i + 1]; ++k) {
    const Pair p = s.fluid_pairs[k];
    rate += c.mass * Dot({v.x - f.vx[p.other], v.y - f.vy[p.other], v.z - f.vz[p.other]},
                         {p.gx, p.gy, p.gz});
  }
  for (uint32_t k = s.wall_begin[i]; k < s.wall_begin[i + 1]; ++k) {
    const Pair p = s.wall_pairs[k];
    // A moving obstacle's samples carry its velocity v_b: Psi_b (v_i - v_b) . grad W.
    rate +=
        c.psi_scale * b.volume[p.other] * Dot(RelativeToSample(b, v, p.other), {p.gx, p.gy, p.gz});
  }
  return rate;
}

// StartWarmStart's per-particle part: kappa_i from what the solve applied last step.
__global__ void WarmStartKernel(Fluid f, Boundary b, Solver s, SphConstants c, float* carried,
                                float dt, float scale, float bound, bool density_solve,
                                unsigned long long* any, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const float rho0 = c.psi_scale;
  float kappa = 0;
  if (carried[i] > 0) {
    const float rate = DensityRate(f, b, s, c, i);
    const bool compressing =
        density_solve ? f.density[i] + dt * rate > rho0 : rate > 0 && f.density[i] >= rho0;
    if (compressing) {
      const float warm = scale * carried[i], cap = bound * s.alpha[i];
      kappa = cap < warm ? cap : warm;  // std::min
    }
  }
  s.kappa[i] = kappa;
  carried[i] = 0;
  if (kappa > 0) *any = 1;  // every writer writes the same value
}

// One iteration's error and kappa: the divergence solve (density_solve false) or the density
// solve.
__global__ void SolveErrorKernel(Fluid f, Boundary b, Solver s, SphConstants c, float dt,
                                 float inv_dt_power, bool density_solve, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const float rho0 = c.psi_scale;
  if (density_solve) {
    const float predicted = f.density[i] + dt * DensityRate(f, b, s, c, i);
    const float difference = predicted - rho0;
    const float excess = difference < 0.0f ? 0.0f : difference;  // std::max(., 0)
    s.error[i] = excess;
    const float cap = kMaxCorrection * rho0;
    s.kappa[i] = (cap < excess ? cap : excess) * inv_dt_power * s.alpha[i];
  } else {
    float rate = 0;
    if (f.density[i] >= rho0) {
      const float r = DensityRate(f, b, s, c, i);
      rate = r < 0.0f ? 0.0f : r;  // std::max(r, 0)
    }
    s.error[i] = rate;
    s.kappa[i] = rate * s.alpha[i] * inv_dt_power;
  }
}

__global__ void KappaOverRhoKernel(Fluid f, Solver s, uint32_t n) {
  const uint32_t j = blockIdx.x * blockDim.x + threadIdx.x;
  if (j < n) s.error[j] = s.kappa[j] / f.density[j];
}

// ExtrapolateKappa: kappa_b = sum_i w_bi kappa_i / rho_i.
__global__ void ExtrapolateKappaKernel(Solver s, uint32_t nb) {
  const uint32_t o = blockIdx.x * blockDim.x + threadIdx.x;
  if (o >= nb) return;
  float kappa = 0;
  for (uint32_t k = s.bn_begin[o]; k < s.bn_begin[o + 1]; ++k) {
    kappa += s.bn_weight[k] * s.error[s.bn_fluid[k]];
  }
  s.kappa_b[o] = kappa;
}

// ApplyKappa's per-particle part (s.error holds kappa / rho).
__global__ void ApplyKappaKernel(Fluid f, Boundary b, Solver s, SphConstants c, float dt,
                                 float* applied, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const float ki = s.error[i];
  F3 fluid{0, 0, 0}, wall{0, 0, 0};
  for (uint32_t k = s.fluid_begin[i]; k < s.fluid_begin[i + 1]; ++k) {
    const Pair p = s.fluid_pairs[k];
    const float w = ki + s.error[p.other];
    fluid.x += w * p.gx, fluid.y += w * p.gy, fluid.z += w * p.gz;
  }
  for (uint32_t k = s.wall_begin[i]; k < s.wall_begin[i + 1]; ++k) {
    const Pair p = s.wall_pairs[k];
    const float w = b.volume[p.other] * (ki + s.kappa_b[p.other]);
    wall.x += w * p.gx, wall.y += w * p.gy, wall.z += w * p.gz;
  }
  f.vx[i] -= dt * (c.mass * fluid.x + c.psi_scale * wall.x);
  f.vy[i] -= dt * (c.mass * fluid.y + c.psi_scale * wall.y);
  f.vz[i] -= dt * (c.mass * fluid.z + c.psi_scale * wall.z);
  s.kappa_sum[i] += s.kappa[i] * dt;
  applied[i] += s.kappa[i];
}

__global__ void ScaleKernel(float* values, float scale, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) values[i] *= scale;
}

__global__ void AddGravityKernel(Fluid f, float gravity, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  f.ax[i] += 0.0f, f.ay[i] += gravity, f.az[i] += 0.0f;
}

__global__ void PredictVelocityKernel(Fluid f, float dt, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  f.vx[i] += f.ax[i] * dt, f.vy[i] += f.ay[i] * dt, f.vz[i] += f.az[i] * dt;
}

__global__ void PressureKernel(Fluid f, Solver s, float scale, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) f.pressure[i] = scale * s.kappa_sum[i] * f.density[i];
}

// IntegratePositions: the speed limit, the wall contact, x += v dt.
__global__ void IntegrateKernel(Fluid f, SphConstants c, Surfaces surfaces, float dt, float limit,
                                unsigned long long* limited, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  F3 v{f.vx[i], f.vy[i], f.vz[i]};
  const float speed2 = Norm2(v);
  if (speed2 > limit * limit) {
    const float k = limit / sqrtf(speed2);
    v.x *= k, v.y *= k, v.z *= k;
    atomicAdd(limited, 1ull);  // an integer count: the same whatever the order
  }
  const F3 x{f.x[i], f.y[i], f.z[i]};
  LimitApproachToSurfaces(c, surfaces, x, dt, v);
  MoveAndStore(c, surfaces, f, i, x, v, dt);
}

__global__ void PairOtherKernel(const Pair* pairs, uint32_t* other, uint32_t count) {
  const uint32_t k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k < count) other[k] = pairs[k].other;
}

__global__ void SpeedSquaredKernel(Fluid f, float* speed2, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) speed2[i] = Norm2({f.vx[i], f.vy[i], f.vz[i]});
}

__global__ void OwnerCountKernel(const uint32_t* keys, uint32_t* count, uint32_t n) {
  const uint32_t k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k < n) atomicAdd(&count[keys[k]], 1u);  // integer counts: order-independent
}

}  // namespace

struct DfsphPipeline::Impl {
  explicit Impl(int device_index) : device(device_index), stream(device_index) {}

  int device;
  Stream stream;
  DfsphStepConfig config;
  std::vector<std::string> passes;
  uint32_t n = 0;
  DeviceBuffer<float> x, y, z, vx, vy, vz, x2, y2, z2, vx2, vy2, vz2;
  DeviceBuffer<uint32_t> id, id2;
  DeviceBuffer<float> density_stiffness, divergence_stiffness, stiffness2;
  DeviceBuffer<float> density, pressure, ax, ay, az, speed2, acceleration2;
  DeviceBuffer<float> alpha, kappa, error, kappa_sum;
  DeviceBuffer<uint32_t> fluid_count, wall_count, fluid_begin, wall_begin;
  DeviceBuffer<Pair> fluid_pairs, wall_pairs;
  DeviceBuffer<uint32_t> wall_owner, wall_owner_sorted, wall_b, wall_b_sorted;
  GridSorter sorter;
  uint32_t nb = 0;
  DeviceBuffer<float> bx, by, bz, bvolume, bvx, bvy, bvz, bunused;
  DeviceBuffer<uint8_t> bno_slip;
  GridSorter boundary_sorter;
  MovingBoundary moving;
  float obstacle_speed = 0;  // m/s, the contact's fastest obstacle (MoveSurfaces)
  DeviceBuffer<uint32_t> bn_count, bn_begin;
  DeviceBuffer<float> bn_weight, hydrostatic, kappa_b;
  mutable DeviceBuffer<float> frame_staging;  // DownloadById's
  mutable ProbeGatherer probe_gatherer;
  mutable RankSubset rank_subset;  // DownloadBelowRank's
  mutable ViewSubset view_subset;  // DownloadViewSubset's
  DeviceBuffer<SphereObstacle> spheres;
  DeviceBuffer<BoxObstacle> boxes;
  DeviceBuffer<float> device_maxima;
  DeviceBuffer<long long> partial_sums, device_sum;
  DeviceBuffer<uint32_t> device_totals;
  DeviceBuffer<unsigned long long> device_flags;  // [0] limited, [1] non-finite, [2] any kappa
  PinnedBuffer<float> maxima;
  PinnedBuffer<long long> sum;
  PinnedBuffer<uint32_t> totals;
  PinnedBuffer<unsigned long long> flags;
  DeviceBuffer<unsigned char> temp;
  EventTimer timer;
  size_t pass = 0;

  cudaStream_t s() const { return stream.get(); }
  unsigned Blocks(uint32_t count) const { return (count + kBlock - 1) / kBlock; }
  void BeginPass() { timer.Record(pass++, s()); }

  Fluid View() {
    return {x.data(),       y.data(),        z.data(),  vx.data(), vy.data(), vz.data(), id.data(),
            density.data(), pressure.data(), ax.data(), ay.data(), az.data(), nullptr};
  }
  Boundary BoundaryView() {
    return {bx.data(),
            by.data(),
            bz.data(),
            bvolume.data(),
            bno_slip.data(),
            bunused.data(),
            bunused.data(),
            bvx.data(),
            bvy.data(),
            bvz.data(),
            nb,
            moving.ux(),
            moving.uy(),
            moving.uz()};
  }
  Solver SolverView() {
    return {alpha.data(),       kappa.data(),
            error.data(),       kappa_sum.data(),
            fluid_begin.data(), wall_begin.data(),
            fluid_pairs.data(), wall_pairs.data(),
            bn_begin.data(),    wall_owner_sorted.data(),
            bn_weight.data(),   hydrostatic.data(),
            kappa_b.data()};
  }
  Surfaces SurfaceView() {
    Surfaces surfaces{
        spheres.data(), int(config.spheres.size()), boxes.data(), int(config.boxes.size()), {},
        obstacle_speed};
    for (int a = 0; a < 3; ++a) surfaces.periodic[a] = config.grid.periodic[a];
    return surfaces;
  }

  void Temp(size_t bytes) { temp.Resize(bytes > 0 ? bytes : 1); }

  template <class T>
  void Gather(const uint32_t* order, DeviceBuffer<T>& data, DeviceBuffer<T>& target, uint32_t m) {
    GatherByOrder(order, data.data(), target.data(), m, s());
    data.swap(target);
  }

  // begin[0, count] = exclusive sums of count[0, count) (count[count] must be 0).
  void ExclusiveSum(uint32_t* counts, uint32_t* begin, uint32_t count) {
    size_t bytes = 0;
    CheckCuda(cub::DeviceScan::ExclusiveSum(nullptr, bytes, counts, begin, int64_t(count) + 1, s()),
              "sizing a scan");
    Temp(bytes);
    bytes = temp.capacity();
    CheckCuda(
        cub::DeviceScan::ExclusiveSum(temp.data(), bytes, counts, begin, int64_t(count) + 1, s()),
        "scanning counts");
  }

  float Max(const float* values) {
    size_t bytes = 0;
    CheckCuda(cub::DeviceReduce::Max(nullptr, bytes, values, device_maxima.data(), int64_t(n), s()),
              "sizing a maximum");
    Temp(bytes);
    bytes = temp.capacity();
    CheckCuda(
        cub::DeviceReduce::Max(temp.data(), bytes, values, device_maxima.data(), int64_t(n), s()),
        "reducing a maximum");
    maxima.CopyFrom(device_maxima, 1, s());
    CheckCuda(cudaStreamSynchronize(s()), "reading a maximum");
    const float m = maxima.data()[0];
    return m > 0 ? m : 0.0f;  // the CPU's maxima start from 0
  }

  // The mean error of bender_koschier_solver.cc's stopping tests (MeanError): the mean of
  // values[k] * factor summed as fixed-point integers, the CPU's bits whatever the order.
  double MeanError(const float* values, double factor) {
    if (n == 0) return 0;
    const uint32_t chunk = (n + kSumBlocks - 1) / kSumBlocks;
    const unsigned blocks = (n + chunk - 1) / chunk;
    PartialFixedPointSumKernel<<<blocks, kSumThreads, 0, s()>>>(values, n, chunk, factor,
                                                                partial_sums.data());
    FinalFixedPointSumKernel<<<1, kSumBlocks, 0, s()>>>(partial_sums.data(), blocks,
                                                        device_sum.data());
    sum.CopyFrom(device_sum, 1, s());
    CheckCuda(cudaStreamSynchronize(s()), "summing the solve's error");
    return dysa::FromFixedPoint(int64_t(sum.data()[0])) / double(n);
  }

  void ApplyKappa(float dt, float* applied) {
    const Fluid f = View();
    const Solver sv = SolverView();
    KappaOverRhoKernel<<<Blocks(n), kBlock, 0, s()>>>(f, sv, n);
    if (nb > 0) ExtrapolateKappaKernel<<<Blocks(nb), kBlock, 0, s()>>>(sv, nb);
    ApplyKappaKernel<<<Blocks(n), kBlock, 0, s()>>>(f, BoundaryView(), sv, config.constants, dt,
                                                    applied, n);
  }

  // StartWarmStart: applies warm_start of what the solve applied last step, where compressing.
  void StartWarmStart(float dt, bool density_solve, float warm_start, float* carried) {
    const float rho0 = config.constants.psi_scale;
    const float scale = warm_start / (density_solve ? dt * dt : dt);
    const float bound = kMaxCorrection * rho0 / (dt * dt);
    if (scale == 0) {
      CheckCuda(cudaMemsetAsync(carried, 0, n * sizeof(float), s()), "clearing the warm start");
      return;
    }
    CheckCuda(cudaMemsetAsync(device_flags.data() + 2, 0, sizeof(unsigned long long), s()),
              "clearing a flag");
    WarmStartKernel<<<Blocks(n), kBlock, 0, s()>>>(View(), BoundaryView(), SolverView(),
                                                   config.constants, carried, dt, scale, bound,
                                                   density_solve, device_flags.data() + 2, n);
    flags.CopyFrom(device_flags, 3, s());
    CheckCuda(cudaStreamSynchronize(s()), "starting a solve warm");
    if (flags.data()[2] != 0) ApplyKappa(dt, carried);
  }

  // The solve loop of DivergenceSolve / DensitySolve: at least 2, at most max_iterations
  // iterations, until the mean error (times error_scale) is within the tolerance.
  // The mean error the stopping test reads is the mean of error * (error_times / error_over), the
  // CPU's factor (MeanError in bender_koschier_solver.cc).
  SolveResult Solve(float dt, bool density_solve, const SolveSettings& settings, double error_times,
                    double error_over, float inv_dt_power, float* carried) {
    StartWarmStart(dt, density_solve, settings.warm_start, carried);
    SolveResult result;
    int iteration = 0;
    for (;; ++iteration) {
      SolveErrorKernel<<<Blocks(n), kBlock, 0, s()>>>(View(), BoundaryView(), SolverView(),
                                                      config.constants, dt, inv_dt_power,
                                                      density_solve, n);
      result.error = MeanError(error.data(), error_times / error_over);
      if (iteration >= 2 && result.error <= settings.tolerance) break;
      if (iteration == settings.max_iterations) {
        result.capped = true;
        break;
      }
      ApplyKappa(dt, carried);
    }
    result.iterations = iteration;
    // FinishWarmStart: the step's total back to the step-free form.
    ScaleKernel<<<Blocks(n), kBlock, 0, s()>>>(carried, density_solve ? dt * dt : dt, n);
    return result;
  }
};

DfsphPipeline::DfsphPipeline(int device) : impl_(std::make_unique<Impl>(device)) {}
DfsphPipeline::~DfsphPipeline() = default;

size_t DfsphPipeline::size() const { return impl_->n; }

void DfsphPipeline::DownloadById(float* position, float* velocity, float* density) const {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  const uint32_t* id = m.id.data();
  if (position)
    cuda::DownloadById(id, m.x.data(), m.y.data(), m.z.data(), m.n, position, m.frame_staging,
                       m.s());
  if (velocity)
    cuda::DownloadById(id, m.vx.data(), m.vy.data(), m.vz.data(), m.n, velocity, m.frame_staging,
                       m.s());
  if (density)
    cuda::DownloadById(id, m.density.data(), nullptr, nullptr, m.n, density, m.frame_staging,
                       m.s());
}

void DfsphPipeline::GatherProbes(const ProbeGatherPlan& plan, ProbeGather& out) const {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  m.probe_gatherer.Gather(ProbeParticlesOf(m), plan, m.stream.get(), out);
}

RankSubsetCopy DfsphPipeline::DownloadBelowRank(uint32_t threshold, bool position, bool velocity,
                                                bool density) const {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  return m.rank_subset.Download(SubsetParticlesOf(m), threshold, position, velocity, density,
                                m.stream.get());
}

RankSubsetCopy DfsphPipeline::DownloadViewSubset(const ViewSubsetRequest& request, uint64_t budget,
                                                 bool position, bool velocity, bool density) const {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  return m.view_subset.Download(SubsetParticlesOf(m), request, budget, position, velocity, density,
                                m.stream.get());
}

std::vector<std::string> DfsphPipeline::Configure(const DfsphStepConfig& config,
                                                  const BoundaryCloud& boundary) {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  cudaStream_t s = m.s();
  m.config = config;
  m.spheres.Assign(config.spheres, s);
  m.boxes.Assign(config.boxes, s);
  m.sorter.Configure(config.grid);
  m.boundary_sorter.Configure(config.grid);
  m.nb = uint32_t(boundary.volume.size());
  const uint32_t nb = m.nb > 0 ? m.nb : 1;
  for (DeviceBuffer<float>* b : {&m.bx, &m.by, &m.bz, &m.bvolume, &m.bvx, &m.bvy, &m.bvz,
                                 &m.bunused, &m.hydrostatic, &m.kappa_b}) {
    b->Resize(nb);
    b->Zero(s);
  }
  m.bno_slip.Resize(nb);
  m.bx.Assign(boundary.x, s), m.by.Assign(boundary.y, s), m.bz.Assign(boundary.z, s);
  m.bvolume.Assign(boundary.volume, s);
  m.bno_slip.Assign(boundary.no_slip, s);
  m.boundary_sorter.Reserve(m.nb);
  m.boundary_sorter.Sort(config.grid, m.bx.data(), m.by.data(), m.bz.data(), m.nb, s);
  if (m.nb > 0) {  // the identity when the host's order is the grid's (wcsph_pipeline.cu)
    const uint32_t* order = m.boundary_sorter.order();
    DeviceBuffer<float> scratch;
    scratch.Resize(m.nb);
    for (DeviceBuffer<float>* b : {&m.bx, &m.by, &m.bz, &m.bvolume}) {
      m.Gather(order, *b, scratch, m.nb);
    }
    DeviceBuffer<uint8_t> flags;
    flags.Resize(m.nb);
    m.Gather(order, m.bno_slip, flags, m.nb);
  }
  m.bn_count.Resize(size_t(nb) + 1);
  m.bn_begin.Resize(size_t(nb) + 1);
  m.moving.Configure(boundary, s);
  m.obstacle_speed = 0;
  m.passes.clear();
  if (m.moving.active()) m.passes.push_back("move_boundary");
  for (const char* name :
       {"neighbour_grid", "density", "boundary_pressure", "divergence_solve", "external_forces"}) {
    m.passes.push_back(name);
  }
  if (config.viscosity) {
    m.passes.push_back("viscosity");
    if (config.wall_viscosity) m.passes.push_back("wall_viscosity");
  }
  for (const char* name : {"time_step", "predict_velocity", "density_solve", "integrate"}) {
    m.passes.push_back(name);
  }
  m.timer.Resize(m.passes.size() + 1);
  m.device_maxima.Resize(1);
  m.maxima.Resize(1);
  m.partial_sums.Resize(kSumBlocks);
  m.device_sum.Resize(1);
  m.sum.Resize(1);
  m.device_totals.Resize(2);
  m.totals.Resize(2);
  m.device_flags.Resize(3);
  m.flags.Resize(3);
  CheckCuda(cudaStreamSynchronize(s), "configuring the dfsph step");
  return m.passes;
}

void DfsphPipeline::Upload(size_t n, const uint32_t* id, const float* position,
                           const float* velocity, const float* density_stiffness,
                           const float* divergence_stiffness) {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  if (n > uint64_t(UINT32_MAX) / 2) throw std::length_error("too many particles for the GPU");
  const uint32_t count = uint32_t(n > 0 ? n : 1);
  for (DeviceBuffer<float>* b : {&m.x,
                                 &m.y,
                                 &m.z,
                                 &m.vx,
                                 &m.vy,
                                 &m.vz,
                                 &m.x2,
                                 &m.y2,
                                 &m.z2,
                                 &m.vx2,
                                 &m.vy2,
                                 &m.vz2,
                                 &m.density_stiffness,
                                 &m.divergence_stiffness,
                                 &m.stiffness2,
                                 &m.density,
                                 &m.pressure,
                                 &m.ax,
                                 &m.ay,
                                 &m.az,
                                 &m.speed2,
                                 &m.acceleration2,
                                 &m.alpha,
                                 &m.kappa,
                                 &m.error,
                                 &m.kappa_sum}) {
    b->Resize(count);
  }
  m.id.Resize(count), m.id2.Resize(count);
  for (DeviceBuffer<uint32_t>* b : {&m.fluid_count, &m.wall_count, &m.fluid_begin, &m.wall_begin}) {
    b->Resize(size_t(count) + 1);
  }
  m.sorter.Reserve(uint32_t(n));
  m.n = uint32_t(n);
  cudaStream_t s = m.s();
  UploadInterleaved(position, n, m.x, m.y, m.z, s);
  UploadInterleaved(velocity, n, m.vx, m.vy, m.vz, s);
  if (n > 0) {
    CheckCuda(cudaMemcpyAsync(m.id.data(), id, n * sizeof(uint32_t), cudaMemcpyHostToDevice, s),
              "uploading ids");
    CheckCuda(cudaMemcpyAsync(m.density_stiffness.data(), density_stiffness, n * sizeof(float),
                              cudaMemcpyHostToDevice, s),
              "uploading the warm start");
    CheckCuda(cudaMemcpyAsync(m.divergence_stiffness.data(), divergence_stiffness,
                              n * sizeof(float), cudaMemcpyHostToDevice, s),
              "uploading the warm start");
  }
  m.density.Zero(s), m.pressure.Zero(s);
  CheckCuda(cudaStreamSynchronize(s), "uploading particles");
}

void DfsphPipeline::Download(uint32_t* id, float* position, float* velocity, float* density,
                             float* pressure, float* density_stiffness,
                             float* divergence_stiffness) const {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  cudaStream_t s = m.s();
  if (id) m.id.CopyTo(id, m.n, s);
  if (position) DownloadInterleaved(m.x, m.y, m.z, m.n, position, s);
  if (velocity) DownloadInterleaved(m.vx, m.vy, m.vz, m.n, velocity, s);
  if (density) m.density.CopyTo(density, m.n, s);
  if (pressure) m.pressure.CopyTo(pressure, m.n, s);
  if (density_stiffness) m.density_stiffness.CopyTo(density_stiffness, m.n, s);
  if (divergence_stiffness) m.divergence_stiffness.CopyTo(divergence_stiffness, m.n, s);
  CheckCuda(cudaStreamSynchronize(s), "downloading particles");
}

void DfsphPipeline::MoveSurfaces(const std::vector<SphereObstacle>& spheres,
                                 const std::vector<BoxObstacle>& boxes, float obstacle_speed) {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  m.spheres.Assign(spheres, m.s());
  m.boxes.Assign(boxes, m.s());
  m.obstacle_speed = obstacle_speed;
}

float DfsphPipeline::Prepare(float gravity, uint32_t max_per_cell,
                             const ObstacleMotionTable& motion) {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  cudaStream_t s = m.s();
  const uint32_t n = m.n;
  const SphConstants c = m.config.constants;
  m.pass = 0;

  if (m.moving.active()) {
    m.BeginPass();  // move_boundary
    m.moving.Move(motion.offset, motion.velocity, m.config.grid, m.boundary_sorter, m.bx.data(),
                  m.by.data(), m.bz.data(), m.bvolume.data(), m.bno_slip.data(), s);
  }
  m.BeginPass();  // neighbour_grid, carrying the warm start along
  m.sorter.Sort(m.config.grid, m.x.data(), m.y.data(), m.z.data(), n, s);
  if (n > 0) {
    const uint32_t* order = m.sorter.order();
    m.Gather(order, m.x, m.x2, n), m.Gather(order, m.y, m.y2, n), m.Gather(order, m.z, m.z2, n);
    m.Gather(order, m.vx, m.vx2, n), m.Gather(order, m.vy, m.vy2, n);
    m.Gather(order, m.vz, m.vz2, n), m.Gather(order, m.id, m.id2, n);
    m.Gather(order, m.density_stiffness, m.stiffness2, n);
    m.Gather(order, m.divergence_stiffness, m.stiffness2, n);
  }
  const DeviceGrid grid = m.sorter.View();
  const DeviceGrid bgrid = m.boundary_sorter.View();

  m.BeginPass();  // density: count the pairs, lay the lists out, fill them
  if (n > 0) {
    CountPairsKernel<<<m.Blocks(n), kBlock, 0, s>>>(grid, bgrid, m.View(), m.BoundaryView(), c,
                                                    m.fluid_count.data(), m.wall_count.data(), n);
    CheckCuda(cudaMemsetAsync(m.fluid_count.data() + n, 0, sizeof(uint32_t), s), "a count");
    CheckCuda(cudaMemsetAsync(m.wall_count.data() + n, 0, sizeof(uint32_t), s), "a count");
    m.ExclusiveSum(m.fluid_count.data(), m.fluid_begin.data(), n);
    m.ExclusiveSum(m.wall_count.data(), m.wall_begin.data(), n);
    CheckCuda(cudaMemcpyAsync(m.device_totals.data(), m.fluid_begin.data() + n, sizeof(uint32_t),
                              cudaMemcpyDeviceToDevice, s),
              "a total");
    CheckCuda(cudaMemcpyAsync(m.device_totals.data() + 1, m.wall_begin.data() + n, sizeof(uint32_t),
                              cudaMemcpyDeviceToDevice, s),
              "a total");
    m.totals.CopyFrom(m.device_totals, 2, s);
    CheckCuda(cudaStreamSynchronize(s), "counting the pairs");
    if (m.sorter.max_count() > max_per_cell) return 0;
  } else {
    m.totals.data()[0] = m.totals.data()[1] = 0;
  }
  const uint32_t fluid_total = m.totals.data()[0], wall_total = m.totals.data()[1];
  m.fluid_pairs.Resize(fluid_total > 0 ? fluid_total : 1);
  for (DeviceBuffer<uint32_t>* b :
       {&m.wall_owner, &m.wall_owner_sorted, &m.wall_b, &m.wall_b_sorted}) {
    b->Resize(wall_total > 0 ? wall_total : 1);
  }
  m.wall_pairs.Resize(wall_total > 0 ? wall_total : 1);
  if (n > 0) {
    DensityAndFactorKernel<<<m.Blocks(n), kBlock, 0, s>>>(
        grid, bgrid, m.View(), m.BoundaryView(), m.SolverView(), c, m.wall_owner.data(), n);
  }

  m.BeginPass();  // boundary_pressure: the walls' fluid neighbours in fluid order, weights
  CheckCuda(cudaMemsetAsync(m.bn_count.data(), 0, (size_t(m.nb) + 1) * sizeof(uint32_t), s),
            "clearing counts");
  if (wall_total > 0) {
    // The b of every wall pair, then a stable sort by b: b's fluid neighbours in fluid order.
    PairOtherKernel<<<m.Blocks(wall_total), kBlock, 0, s>>>(m.wall_pairs.data(), m.wall_b.data(),
                                                            wall_total);
    cub::DoubleBuffer<uint32_t> keys(m.wall_b.data(), m.wall_b_sorted.data());
    cub::DoubleBuffer<uint32_t> values(m.wall_owner.data(), m.wall_owner_sorted.data());
    size_t bytes = 0;
    CheckCuda(cub::DeviceRadixSort::SortPairs(nullptr, bytes, keys, values, int64_t(wall_total), 0,
                                              32, s),
              "sizing the walls' transpose");
    m.Temp(bytes);
    bytes = m.temp.capacity();
    CheckCuda(cub::DeviceRadixSort::SortPairs(m.temp.data(), bytes, keys, values,
                                              int64_t(wall_total), 0, 32, s),
              "transposing the walls' pairs");
    if (values.Current() != m.wall_owner_sorted.data()) m.wall_owner.swap(m.wall_owner_sorted);
    OwnerCountKernel<<<m.Blocks(wall_total), kBlock, 0, s>>>(keys.Current(), m.bn_count.data(),
                                                             wall_total);
    m.bn_weight.Resize(wall_total);
  }
  m.ExclusiveSum(m.bn_count.data(), m.bn_begin.data(), m.nb);
  Periods periods;
  for (int a = 0; a < 3; ++a) periods.length[a] = m.config.period[a];
  if (m.nb > 0) {
    BoundaryWeightsKernel<<<m.Blocks(m.nb), kBlock, 0, s>>>(m.View(), m.BoundaryView(),
                                                            m.SolverView(), c, periods, gravity);
  }
  if (n > 0) {
    HydrostaticAccelerationKernel<<<m.Blocks(n), kBlock, 0, s>>>(
        m.View(), m.BoundaryView(), m.SolverView(), c, m.config.gradient_moment, n);
  }
  CheckCuda(cudaGetLastError(), "launching the dfsph density passes");
  if (n == 0) return 0;
  SpeedSquaredKernel<<<m.Blocks(n), kBlock, 0, s>>>(m.View(), m.speed2.data(), n);
  return m.Max(m.speed2.data());
}

SolveResult DfsphPipeline::DivergenceSolve(double dt, const SolveSettings& settings) {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  m.BeginPass();  // divergence_solve
  if (m.n == 0) return {};
  CheckCuda(cudaMemsetAsync(m.kappa_sum.data(), 0, m.n * sizeof(float), m.s()), "clearing");
  const double rho0 = m.config.constants.rest_density;
  return m.Solve(float(dt), false, settings, dt, rho0, float(1 / dt),
                 m.divergence_stiffness.data());
}

StepMaxima DfsphPipeline::Forces(float gravity) {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  cudaStream_t s = m.s();
  const uint32_t n = m.n;
  const SphConstants c = m.config.constants;
  const unsigned blocks = m.Blocks(n);
  const Fluid f = m.View();
  m.BeginPass();  // external_forces
  if (n > 0) AddGravityKernel<<<blocks, kBlock, 0, s>>>(f, gravity, n);
  const DeviceGrid grid = m.sorter.View();
  const DeviceGrid bgrid = m.boundary_sorter.View();
  if (m.config.viscosity) {
    m.BeginPass();  // viscosity
    if (n > 0) ViscosityKernel<<<blocks, kBlock, 0, s>>>(grid, f, c, n);
    if (m.config.wall_viscosity) {
      m.BeginPass();  // wall_viscosity
      if (m.nb > 0) {
        BoundaryVelocityKernel<<<m.Blocks(m.nb), kBlock, 0, s>>>(grid, bgrid, f, m.BoundaryView(),
                                                                 c);
      }
      if (n > 0)
        WallViscosityKernel<<<blocks, kBlock, 0, s>>>(grid, bgrid, f, m.BoundaryView(), c, n);
    }
  }
  m.BeginPass();  // time_step
  StepMaxima result;
  if (n == 0) return result;
  MaximaInputsKernel<<<blocks, kBlock, 0, s>>>(f, m.speed2.data(), m.acceleration2.data(), n);
  result.speed2 = m.Max(m.speed2.data());
  result.acceleration2 = m.Max(m.acceleration2.data());
  result.density = m.Max(m.density.data());
  return result;
}

SolveResult DfsphPipeline::DensitySolve(float dt, const SolveSettings& settings) {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  const uint32_t n = m.n;
  m.BeginPass();  // predict_velocity
  if (n > 0) PredictVelocityKernel<<<m.Blocks(n), kBlock, 0, m.s()>>>(m.View(), dt, n);
  m.BeginPass();  // density_solve
  if (n == 0) return {};
  const float rho0 = m.config.constants.psi_scale;
  const float inv_dt2 = 1 / (dt * dt);
  SolveResult result =
      m.Solve(dt, true, settings, 1.0, double(rho0), inv_dt2, m.density_stiffness.data());
  PressureKernel<<<m.Blocks(n), kBlock, 0, m.s()>>>(m.View(), m.SolverView(),
                                                    m.config.gradient_moment / dt, n);
  return result;
}

StepOutcome DfsphPipeline::Integrate(float dt, float speed_limit) {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  cudaStream_t s = m.s();
  const uint32_t n = m.n;
  m.BeginPass();  // integrate
  CheckCuda(cudaMemsetAsync(m.device_flags.data(), 0, 2 * sizeof(unsigned long long), s),
            "clearing the step's flags");
  if (n > 0) {
    IntegrateKernel<<<m.Blocks(n), kBlock, 0, s>>>(m.View(), m.config.constants, m.SurfaceView(),
                                                   dt, speed_limit, m.device_flags.data(), n);
  }
  m.timer.Record(m.pass, s);
  const Fluid f = m.View();
  CheckFinite(f.x, f.y, f.z, f.vx, f.vy, f.vz, n, m.device_flags.data() + 1, s);
  CheckCuda(cudaGetLastError(), "launching the dfsph integration");
  m.flags.CopyFrom(m.device_flags, 2, s);
  CheckCuda(cudaStreamSynchronize(s), "running the dfsph step");
  StepOutcome outcome;
  outcome.pass_ms = m.timer.ElapsedMs(m.pass);
  outcome.limited = m.flags.data()[0];
  outcome.finite = m.flags.data()[1] == 0;
  return outcome;
}

uint32_t DfsphPipeline::max_cell_count() const { return impl_->sorter.max_count(); }

uint64_t DfsphPipeline::DeviceBytes() const {
  const Impl& m = *impl_;
  return uint64_t(m.x.capacity()) * (26 * sizeof(float) + 6 * sizeof(uint32_t)) +
         uint64_t(m.fluid_pairs.capacity() + m.wall_pairs.capacity()) * sizeof(Pair) +
         uint64_t(m.wall_owner.capacity()) * 4 * sizeof(uint32_t) +
         uint64_t(m.bn_weight.capacity()) * sizeof(float) +
         uint64_t(m.bx.capacity()) * (10 * sizeof(float) + 2 * sizeof(uint32_t) + 1) +
         m.sorter.DeviceBytes() + m.boundary_sorter.DeviceBytes() + m.moving.DeviceBytes() +
         m.temp.capacity() + m.rank_subset.DeviceBytes() + m.view_subset.DeviceBytes();
}

}  // namespace dysa::cuda
