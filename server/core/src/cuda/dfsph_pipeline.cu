// The dfsph solver's step on the GPU (dfsph_pipeline.h): its buffers, the pressure solves'
// loops and the order of its kernels (dfsph_kernels.cuh).
#include <cuda_runtime.h>

#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_reduce.cuh>
#include <cub/device/device_scan.cuh>
#include <string>

#include "cuda/device_buffer.cuh"
#include "cuda/device_grid.cuh"
#include "cuda/dfsph_kernels.cuh"
#include "cuda/dfsph_pipeline.h"
#include "cuda/dfsph_ranks.cuh"
#include "cuda/fixed_point_sum.cuh"
#include "cuda/physical_arrays.cuh"
#include "cuda/sph_kernels.cuh"

namespace dysa::cuda {

// The particles, the boundary and the obstacles are PhysicalArrays'; these are dfsph's own.
struct DfsphPipeline::Impl : PhysicalArrays {
  explicit Impl(int device_index) : PhysicalArrays(device_index) {}

  DfsphStepConfig config;
  std::vector<std::string> passes;
  DeviceBuffer<float> density_stiffness, divergence_stiffness, stiffness2;
  DeviceBuffer<float> alpha, kappa, error, kappa_sum;
  DeviceBuffer<uint32_t> fluid_count, wall_count, fluid_begin, wall_begin;
  // The pairs' other particles (Solver): 4 bytes a pair, grad W recomputed where it is read.
  DeviceBuffer<uint32_t> fluid_pairs, wall_pairs;
  DeviceBuffer<float4> packed;  // Solver::packed
  DeviceBuffer<uint32_t> wall_owner, wall_owner_sorted, wall_b, wall_b_sorted;
  // The Boundary view's two pressure arrays, which no dfsph kernel uses.
  DeviceBuffer<float> bunused;
  DeviceBuffer<uint32_t> bn_count, bn_begin;
  DeviceBuffer<float> bn_weight, hydrostatic, kappa_b;
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
  // One of several processes (SetProcesses); UsePinnedStaging's buffers.
  DfsphRanks ranks;
  PinnedStaging staging;

  cudaStream_t s() const { return stream.get(); }
  unsigned Blocks(uint32_t count) const { return (count + kBlock - 1) / kBlock; }
  void BeginPass() { timer.Record(pass++, s()); }

  Fluid View() { return FluidOf(*this, nullptr); }
  Boundary BoundaryView() { return BoundaryOf(*this, bunused.data(), bunused.data()); }
  Solver SolverView() {
    return {alpha.data(),
            kappa.data(),
            error.data(),
            kappa_sum.data(),
            fluid_begin.data(),
            wall_begin.data(),
            fluid_pairs.data(),
            wall_pairs.data(),
            packed.data(),
            SeamsOf(sorter.View()),
            SeamsOf(boundary_sorter.View()),
            bn_begin.data(),
            wall_owner_sorted.data(),
            bn_weight.data(),
            hydrostatic.data(),
            kappa_b.data()};
  }
  Surfaces SurfaceView() { return SurfacesOf(*this); }

  void Temp(size_t bytes) { temp.Resize(bytes > 0 ? bytes : 1); }

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
  // values[k] * factor over the owned particles, summed as fixed-point integers (the CPU's bits
  // whatever the order), and on several processes the sum and the count over all of them.
  double MeanError(const float* values, double factor) {
    int64_t sums[2] = {0, ranks.active() ? ranks.owned : int64_t(n)};
    if (n > 0) {
      sums[0] = DeviceFixedPointSum(values, ranks.GhostFlags(), n, factor, partial_sums.data(),
                                    device_sum.data(), sum.data(), s());
    }
    if (ranks.active()) ranks.processes->Sum(sums, 2);
    return sums[1] > 0 ? dysa::FromFixedPoint(sums[0]) / double(sums[1]) : 0;
  }

  // ApplyKappa, and on several processes the ghosts' refresh that follows it there (the next
  // iteration's rates read the neighbours' velocities).
  void ApplyKappa(float dt, float* applied) {
    const Fluid f = View();
    const Solver sv = SolverView();
    if (n > 0) KappaOverRhoKernel<<<Blocks(n), kBlock, 0, s()>>>(f, sv, n);
    if (nb > 0) ExtrapolateKappaKernel<<<Blocks(nb), kBlock, 0, s()>>>(sv, nb);
    if (n > 0) {
      ApplyKappaKernel<<<Blocks(n), kBlock, 0, s()>>>(f, BoundaryView(), sv, config.constants, dt,
                                                      applied, n);
    }
    ranks.RefreshVelocities(vx.data(), vy.data(), vz.data(), s());
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
    if (n > 0) {
      WarmStartKernel<<<Blocks(n), kBlock, 0, s()>>>(View(), BoundaryView(), SolverView(),
                                                     config.constants, carried, dt, scale, bound,
                                                     density_solve, device_flags.data() + 2, n);
    }
    flags.CopyFrom(device_flags, 3, s());
    CheckCuda(cudaStreamSynchronize(s()), "starting a solve warm");
    // Applied on every process or on none, as ApplyKappa refreshes the ghosts (a collective).
    double applies = flags.data()[2] != 0 ? 1 : 0;
    if (ranks.active()) ranks.processes->Max(&applies, 1);
    if (applies > 0) ApplyKappa(dt, carried);
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
      if (n > 0) {
        SolveErrorKernel<<<Blocks(n), kBlock, 0, s()>>>(
            View(), BoundaryView(), SolverView(), config.constants, dt, inv_dt_power, density_solve,
            settings.signed_corrections ? carried : nullptr, n);
      }
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
    if (n > 0) ScaleKernel<<<Blocks(n), kBlock, 0, s()>>>(carried, density_solve ? dt * dt : dt, n);
    return result;
  }
};

DfsphPipeline::DfsphPipeline(int device) : impl_(std::make_unique<Impl>(device)) {
  arrays_ = impl_.get();
}
DfsphPipeline::~DfsphPipeline() = default;

std::vector<std::string> DfsphPipeline::Configure(const DfsphStepConfig& config,
                                                  const BoundaryCloud& boundary) {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  cudaStream_t s = m.s();
  m.config = config;
  m.ConfigureArrays(config.grid, config.spheres, config.boxes, boundary,
                    {&m.bunused, &m.hydrostatic, &m.kappa_b});
  const uint32_t nb = m.nb > 0 ? m.nb : 1;
  m.bn_count.Resize(size_t(nb) + 1);
  m.bn_begin.Resize(size_t(nb) + 1);
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
  m.AllocateFluid(n, {&m.density_stiffness, &m.divergence_stiffness, &m.stiffness2, &m.alpha,
                      &m.kappa, &m.error, &m.kappa_sum});
  const uint32_t count = uint32_t(n > 0 ? n : 1);
  for (DeviceBuffer<uint32_t>* b : {&m.fluid_count, &m.wall_count, &m.fluid_begin, &m.wall_begin}) {
    b->Resize(size_t(count) + 1);
  }
  m.packed.Resize(count);
  m.staging.Upload(
      m, id, position, velocity,
      {{&m.density_stiffness, density_stiffness}, {&m.divergence_stiffness, divergence_stiffness}});
}

void DfsphPipeline::Download(uint32_t* id, float* position, float* velocity, float* density,
                             float* pressure, float* density_stiffness,
                             float* divergence_stiffness) const {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  m.staging.Download(
      m, id, position, velocity, density, pressure,
      {{&m.density_stiffness, density_stiffness}, {&m.divergence_stiffness, divergence_stiffness}});
}

void DfsphPipeline::UsePinnedStaging(bool on) { impl_->staging.on = on; }

void DfsphPipeline::DownloadSortedOrder(uint32_t* id, uint32_t* cells) const {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  m.staging.DownloadSortedOrder(m, id, cells);
}

void DfsphPipeline::SetProcesses(DfsphProcesses* processes, const uint8_t* ghost,
                                 const uint32_t* sent, size_t sent_count, const uint32_t* received,
                                 size_t received_count) {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  m.ranks.Set(processes, ghost, m.n, sent, sent_count, received, received_count, m.s());
}

float DfsphPipeline::MaxSpeed2() {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  if (m.n == 0) return 0;
  SpeedSquaredKernel<<<m.Blocks(m.n), kBlock, 0, m.s()>>>(m.View(), m.ranks.GhostFlags(),
                                                          m.speed2.data(), m.n);
  return m.Max(m.speed2.data());
}

void DfsphPipeline::MoveSurfaces(const std::vector<SphereObstacle>& spheres,
                                 const std::vector<BoxObstacle>& boxes, float obstacle_speed) {
  impl_->MoveSurfaces(spheres, boxes, obstacle_speed);
}

void DfsphPipeline::Prepare(float gravity, uint32_t max_per_cell,
                            const ObstacleMotionTable& motion) {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  cudaStream_t s = m.s();
  const uint32_t n = m.n;
  const SphConstants c = m.config.constants;
  m.pass = 0;
  m.ranks.Set(nullptr, nullptr, 0, nullptr, 0, nullptr, 0, s);  // until SetProcesses

  if (m.moving.active()) {
    m.BeginPass();  // move_boundary
    m.MoveBoundary(m.config.grid, motion);
  }
  m.BeginPass();  // neighbour_grid, carrying the warm start along
  const uint32_t* order = m.SortFluid(m.config.grid);
  if (n > 0) {
    m.Gather(order, m.density_stiffness, m.stiffness2, n);
    m.Gather(order, m.divergence_stiffness, m.stiffness2, n);
  }
  const DeviceGrid grid = m.sorter.View();
  const DeviceGrid bgrid = m.boundary_sorter.View();

  m.BeginPass();  // density: count the pairs, lay the lists out, fill them
  if (n > 0) {
    CountPairsKernel<<<m.Blocks(n), kBlock, 0, s>>>(grid, bgrid, m.View(), m.BoundaryView(), c,
                                                    m.fluid_count.data(), m.wall_count.data(),
                                                    m.packed.data(), n);
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
    if (m.sorter.max_count() > max_per_cell) return;
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
    // (A copy: the sort overwrites both of its key buffers.)
    CheckCuda(cudaMemcpyAsync(m.wall_b.data(), m.wall_pairs.data(), wall_total * sizeof(uint32_t),
                              cudaMemcpyDeviceToDevice, s),
              "copying the walls' pairs");
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
}

SolveResult DfsphPipeline::DivergenceSolve(double dt, const SolveSettings& settings) {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  m.BeginPass();  // divergence_solve
  // On several processes a process without particles still takes part in every collective.
  if (m.n == 0 && !m.ranks.active()) return {};
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
  const float* density = m.density.data();
  if (m.ranks.active()) {  // the ghosts' accelerations and densities are incomplete
    m.ranks.OwnedMaximaInputs(f.vx, f.vy, f.vz, f.ax, f.ay, f.az, density, m.speed2.data(),
                              m.acceleration2.data(), n, s);
    density = m.ranks.owned_density.data();
  } else {
    MaximaInputsKernel<<<blocks, kBlock, 0, s>>>(f, m.speed2.data(), m.acceleration2.data(), n);
  }
  result.speed2 = m.Max(m.speed2.data());
  result.acceleration2 = m.Max(m.acceleration2.data());
  result.density = m.Max(density);
  return result;
}

SolveResult DfsphPipeline::DensitySolve(float dt, const SolveSettings& settings) {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  const uint32_t n = m.n;
  m.BeginPass();  // predict_velocity
  if (n > 0) PredictVelocityKernel<<<m.Blocks(n), kBlock, 0, m.s()>>>(m.View(), dt, n);
  // A ghost's acceleration misses what lies past the ghost layers; the solve reads the
  // neighbours' velocities.
  m.ranks.RefreshVelocities(m.vx.data(), m.vy.data(), m.vz.data(), m.s());
  m.BeginPass();  // density_solve
  if (n == 0 && !m.ranks.active()) return {};
  const float rho0 = m.config.constants.psi_scale;
  const float inv_dt2 = 1 / (dt * dt);
  SolveResult result =
      m.Solve(dt, true, settings, 1.0, double(rho0), inv_dt2, m.density_stiffness.data());
  if (n > 0) {
    PressureKernel<<<m.Blocks(n), kBlock, 0, m.s()>>>(m.View(), m.SolverView(),
                                                      m.config.gradient_moment / dt, n);
  }
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
                                                   dt, speed_limit, m.ranks.GhostFlags(),
                                                   m.device_flags.data(), n);
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

uint64_t DfsphPipeline::DeviceBytes() const {
  const Impl& m = *impl_;
  // Dfsph's own: 7 float arrays (the warm starts and their scratch, alpha, kappa, the error,
  // the kappa sum), the packed positions and 4 count arrays per particle, the pair lists (an
  // index a pair) and the walls' transpose, 3 floats and 2 counts per boundary sample, and on
  // one of several processes the ghost refresh's buffers.
  return m.PhysicalDeviceBytes() + m.ranks.DeviceBytes() +
         uint64_t(m.x.capacity()) * (7 * sizeof(float) + 4 * sizeof(uint32_t)) +
         uint64_t(m.packed.capacity()) * sizeof(float4) +
         uint64_t(m.fluid_pairs.capacity() + m.wall_pairs.capacity()) * sizeof(uint32_t) +
         uint64_t(m.wall_owner.capacity()) * 4 * sizeof(uint32_t) +
         uint64_t(m.bn_weight.capacity()) * sizeof(float) +
         uint64_t(m.bx.capacity()) * (3 * sizeof(float) + 2 * sizeof(uint32_t)) + m.temp.capacity();
}

}  // namespace dysa::cuda
