// The wcsph solver's step on the GPU (wcsph_pipeline.h): its buffers and the order of its
// kernels (wcsph_kernels.cuh, symplectic_kernels.cuh, particle_shifting.cuh).
#include <cuda_runtime.h>

#include <cstring>
#include <cub/device/device_reduce.cuh>
#include <string>
#include <vector>

#include "cuda/device_buffer.cuh"
#include "cuda/device_grid.cuh"
#include "cuda/particle_shifting.cuh"
#include "cuda/physical_arrays.cuh"
#include "cuda/sph_kernels.cuh"
#include "cuda/symplectic_kernels.cuh"
#include "cuda/wcsph_kernels.cuh"
#include "cuda/wcsph_pipeline.h"

namespace dysa::cuda {
namespace {

using namespace sph;  // NOLINT: this file is the wcsph half of those kernels

// MaximaInputsKernel on one of several processes: a ghost (a particle sorted into a cell layer
// along `axis` that this process does not own) counts as 0, which no maximum exceeds (the CPU's
// start at 0), so the maxima are those of the owned particles; `density` receives the densities
// so masked.
__global__ void OwnedMaximaInputsKernel(Fluid f, DeviceGrid grid, const uint8_t* owned_layer,
                                        int axis, float* speed2, float* acceleration2,
                                        float* density, uint32_t n) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const int3 cell = grid.SortedCell(i);
  const int layer = axis == 0 ? cell.x : (axis == 1 ? cell.y : cell.z);
  const bool owned = owned_layer[layer] != 0;
  speed2[i] = owned ? Norm2({f.vx[i], f.vy[i], f.vz[i]}) : 0.0f;
  acceleration2[i] = owned ? Norm2({f.ax[i], f.ay[i], f.az[i]}) : 0.0f;
  density[i] = owned ? f.density[i] : 0.0f;
}

// Copies `count` values into page-locked `staging` (grown as needed) and returns where they
// landed; null for no values.
template <class T>
const T* Stage(PinnedBuffer<T>& staging, const T* values, size_t count) {
  if (!values || count == 0) return nullptr;
  staging.Resize(count);
  std::memcpy(staging.data(), values, count * sizeof(T));
  return staging.data();
}

}  // namespace

// The particles, the boundary and the obstacles are PhysicalArrays'; these are wcsph's own.
struct WcsphPipeline::Impl : PhysicalArrays {
  explicit Impl(int device_index) : PhysicalArrays(device_index) {}

  WcsphStepConfig config;
  std::vector<std::string> passes;
  DeviceBuffer<float> p_over_rho2;
  // The density the continuity equation carries (permuted with the particles), its scratch for
  // the permutation, and the step's D rho / Dt; carried_ready false until InitialDensityKernel.
  DeviceBuffer<float> carried, carried2, density_rate;
  bool carried_ready = false;
  // The interaction sweep's packed neighbour state (PackedFluid), written by the pressure pass.
  DeviceBuffer<float4> packed_position, packed_velocity;
  // The predictor-corrector's x^n, v^n, rho^n (allocated at the first Predict); predicted
  // between Predict and Correct, when the corrector's sort permutes them too.
  DeviceBuffer<float> start_x, start_y, start_z, start_vx, start_vy, start_vz, start_density;
  bool predicted = false;
  // The particle shifting's displacement rate (allocated at its first pass).
  DeviceBuffer<float> shift_x, shift_y, shift_z;
  // The boundary's pressures per step.
  DeviceBuffer<float> bpressure, bp_over_rho2;
  DeviceBuffer<float> device_maxima;              // [0] |v|^2, [1] |a|^2, [2] density
  DeviceBuffer<unsigned long long> device_flags;  // [0] unused, [1] non-finite
  PinnedBuffer<float> maxima;
  PinnedBuffer<unsigned long long> flags;
  DeviceBuffer<unsigned char> reduce_temp;
  // SetOwnedLayers's mask (empty: none) and the masked densities the maxima read.
  std::vector<uint8_t> owned_host;
  DeviceBuffer<uint8_t> owned_layers;
  int owned_axis = 0;
  DeviceBuffer<float> owned_density;
  // UsePinnedStaging's buffers: positions and velocities (xyz), the carried density, ids; the
  // download's densities and pressures too.
  bool pinned_staging = false;
  PinnedBuffer<float> stage_position, stage_velocity, stage_carried, stage_density, stage_pressure;
  PinnedBuffer<uint32_t> stage_id;
  EventTimer timer;
  size_t pass = 0;

  Fluid View() { return FluidOf(*this, p_over_rho2.data()); }
  Boundary BoundaryView() { return BoundaryOf(*this, bpressure.data(), bp_over_rho2.data()); }
  Surfaces SurfaceView() { return SurfacesOf(*this); }

  void Allocate(size_t count) {
    AllocateFluid(count, {&p_over_rho2, &carried, &carried2, &density_rate});
    const uint32_t elements = uint32_t(count > 0 ? count : 1);
    packed_position.Resize(elements);
    packed_velocity.Resize(elements);
    size_t bytes = 0;
    CheckCuda(cub::DeviceReduce::Max(nullptr, bytes, speed2.data(), device_maxima.data(),
                                     int64_t(elements)),
              "sizing the maxima");
    reduce_temp.Resize(bytes > 0 ? bytes : 1);
  }

  // The shifting pass where it is on (timed as the next pass); the shift to integrate with.
  Shift ShiftingPass();

  StepStart StartView() {
    return {start_x.data(),  start_y.data(),  start_z.data(),      start_vx.data(),
            start_vy.data(), start_vz.data(), start_density.data()};
  }

  // move_boundary ... wall_viscosity (Forces), each pass timed from index `pass` on.
  void ForcePasses(float gravity, float hydrostatic, const ObstacleMotionTable& motion);

  // After the last pass's kernel (`what` names it in errors): the finiteness check, and every
  // pass's time.
  StepOutcome FinishStep(const char* what) {
    cudaStream_t s = stream.get();
    timer.Record(pass, s);
    const Fluid f = View();
    CheckFinite(f.x, f.y, f.z, f.vx, f.vy, f.vz, n, device_flags.data() + 1, s);
    CheckCuda(cudaGetLastError(), (std::string("launching ") + what).c_str());
    flags.CopyFrom(device_flags, 2, s);
    CheckCuda(cudaStreamSynchronize(s), (std::string("running ") + what).c_str());
    StepOutcome outcome;
    outcome.pass_ms = timer.ElapsedMs(pass);
    outcome.finite = flags.data()[1] == 0;
    return outcome;
  }

  void Max(const float* values, float* out) {
    size_t bytes = reduce_temp.capacity();
    CheckCuda(
        cub::DeviceReduce::Max(reduce_temp.data(), bytes, values, out, int64_t(n), stream.get()),
        "reducing the step's maxima");
  }
};

WcsphPipeline::WcsphPipeline(int device) : impl_(std::make_unique<Impl>(device)) {
  arrays_ = impl_.get();
}
WcsphPipeline::~WcsphPipeline() = default;

std::vector<std::string> WcsphPipeline::Configure(const WcsphStepConfig& config,
                                                  const BoundaryCloud& boundary) {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  cudaStream_t s = m.stream.get();
  m.config = config;
  m.ConfigureArrays(config.grid, config.spheres, config.boxes, boundary,
                    {&m.bpressure, &m.bp_over_rho2});
  m.passes.clear();
  if (m.moving.active()) m.passes.push_back("move_boundary");
  for (const char* name : {"neighbour_grid", "pressure", "boundary_pressure", "interactions"}) {
    m.passes.push_back(name);
  }
  m.passes.push_back("time_step");
  if (config.symplectic) {
    // The force passes again at t + dt/2 (BeckerTeschnerSolver::BuildPasses's names).
    const size_t forces_end = m.passes.size() - 1;
    m.passes.push_back("predict");
    for (size_t k = 0; k < forces_end; ++k) m.passes.push_back(m.passes[k] + "_corrector");
  }
  if (config.shifting > 0) m.passes.push_back("shifting");
  m.passes.push_back(config.symplectic ? "correct" : "integrate");
  m.timer.Resize(m.passes.size() + 1);
  m.device_maxima.Resize(3);
  m.device_flags.Resize(2);
  m.maxima.Resize(3);
  m.flags.Resize(2);
  CheckCuda(cudaStreamSynchronize(s), "configuring the wcsph step");
  return m.passes;
}

void WcsphPipeline::Upload(size_t n, const uint32_t* id, const float* position,
                           const float* velocity, const float* carried_density) {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  m.Allocate(n);
  cudaStream_t s = m.stream.get();
  if (m.pinned_staging) {
    id = Stage(m.stage_id, id, n);
    position = Stage(m.stage_position, position, 3 * n);
    velocity = Stage(m.stage_velocity, velocity, 3 * n);
    carried_density = Stage(m.stage_carried, carried_density, n);
  }
  m.EnqueueUpload(id, position, velocity);
  m.carried_ready = carried_density != nullptr;
  if (carried_density && n > 0) {
    CheckCuda(cudaMemcpyAsync(m.carried.data(), carried_density, n * sizeof(float),
                              cudaMemcpyHostToDevice, s),
              "uploading the carried density");
  }
  CheckCuda(cudaStreamSynchronize(s), "uploading particles");
}

void WcsphPipeline::Download(uint32_t* id, float* position, float* velocity, float* density,
                             float* pressure) const {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  cudaStream_t s = m.stream.get();
  if (!m.pinned_staging) {
    m.EnqueueDownload(id, position, velocity, density, pressure);
    CheckCuda(cudaStreamSynchronize(s), "downloading particles");
    return;
  }
  // Into the page-locked buffers, then on the host where the caller wants them.
  const size_t n = m.n;
  for (PinnedBuffer<float>* b : {&m.stage_position, &m.stage_velocity}) b->Resize(3 * n + 1);
  for (PinnedBuffer<float>* b : {&m.stage_density, &m.stage_pressure}) b->Resize(n + 1);
  m.stage_id.Resize(n + 1);
  m.EnqueueDownload(id ? m.stage_id.data() : nullptr, position ? m.stage_position.data() : nullptr,
                    velocity ? m.stage_velocity.data() : nullptr,
                    density ? m.stage_density.data() : nullptr,
                    pressure ? m.stage_pressure.data() : nullptr);
  CheckCuda(cudaStreamSynchronize(s), "downloading particles");
  auto unstage = [n](auto* out, const auto& staging, size_t per_particle) {
    if (out && n > 0) std::memcpy(out, staging.data(), n * per_particle * sizeof(*out));
  };
  unstage(id, m.stage_id, 1);
  unstage(position, m.stage_position, 3);
  unstage(velocity, m.stage_velocity, 3);
  unstage(density, m.stage_density, 1);
  unstage(pressure, m.stage_pressure, 1);
}

void WcsphPipeline::UsePinnedStaging(bool on) { impl_->pinned_staging = on; }

void WcsphPipeline::SetOwnedLayers(int axis, const std::vector<uint8_t>& owned) {
  Impl& m = *impl_;
  if (owned == m.owned_host && axis == m.owned_axis) return;
  DeviceScope scope(m.device);
  m.owned_host = owned;
  m.owned_axis = axis;
  if (!owned.empty()) m.owned_layers.Assign(owned, m.stream.get());
}

void WcsphPipeline::DownloadSortedCells(uint32_t* cells) const {
  Impl& m = *impl_;
  if (m.n == 0) return;
  DeviceScope scope(m.device);
  cudaStream_t s = m.stream.get();
  CheckCuda(cudaMemcpyAsync(cells, m.sorter.View().sorted_key, size_t(m.n) * sizeof(uint32_t),
                            cudaMemcpyDeviceToHost, s),
            "downloading the sorted cells");
  CheckCuda(cudaStreamSynchronize(s), "downloading the sorted cells");
}

bool WcsphPipeline::DownloadCarriedDensity(float* carried_density) const {
  Impl& m = *impl_;
  if (!m.carried_ready) return false;
  DeviceScope scope(m.device);
  cudaStream_t s = m.stream.get();
  m.carried.CopyTo(carried_density, m.n, s);
  CheckCuda(cudaStreamSynchronize(s), "downloading the carried density");
  return true;
}

void WcsphPipeline::MoveSurfaces(const std::vector<SphereObstacle>& spheres,
                                 const std::vector<BoxObstacle>& boxes, float obstacle_speed) {
  impl_->MoveSurfaces(spheres, boxes, obstacle_speed);
}

void WcsphPipeline::Impl::ForcePasses(float gravity, float hydrostatic,
                                      const ObstacleMotionTable& motion) {
  Impl& m = *this;
  const WcsphStepConfig& cfg = m.config;
  const SphConstants c = cfg.constants;
  const uint32_t n = m.n;
  cudaStream_t s = m.stream.get();
  const unsigned blocks = (n + kBlock - 1) / kBlock;
  const unsigned boundary_blocks = (m.nb + kBlock - 1) / kBlock;
  auto begin_pass = [&] { m.timer.Record(m.pass++, s); };

  if (m.moving.active()) {
    begin_pass();  // move_boundary
    m.MoveBoundary(cfg.grid, motion);
  }
  begin_pass();  // neighbour_grid
  const uint32_t* order = m.SortFluid(cfg.grid);
  if (n > 0) {
    if (m.carried_ready) m.Gather(order, m.carried, m.carried2, n);
    if (m.predicted) {
      m.Gather(order, m.start_x, m.x2, n), m.Gather(order, m.start_y, m.y2, n);
      m.Gather(order, m.start_z, m.z2, n), m.Gather(order, m.start_vx, m.vx2, n);
      m.Gather(order, m.start_vy, m.vy2, n), m.Gather(order, m.start_vz, m.vz2, n);
      m.Gather(order, m.start_density, m.carried2, n);
    }
  }
  const DeviceGrid grid = m.sorter.View();
  const DeviceGrid bgrid = m.boundary_sorter.View();
  const Fluid f = m.View();
  const Boundary b = m.BoundaryView();
  const PackedFluid packed{m.packed_position.data(), m.packed_velocity.data()};
  begin_pass();  // pressure
  if (n > 0) {
    if (!m.carried_ready) {
      InitialDensityKernel<<<blocks, kBlock, 0, s>>>(grid, bgrid, f, b, c, m.carried.data(), n);
    }
    PressureKernel<<<blocks, kBlock, 0, s>>>(f, c, m.carried.data(), packed, n);
  }
  m.carried_ready = true;
  begin_pass();  // boundary_pressure (and the no-slip walls' extrapolated velocity)
  if (m.nb > 0) {
    BoundaryPressureKernel<<<boundary_blocks, kBlock, 0, s>>>(grid, bgrid, f, b, c, packed,
                                                              gravity);
    if (cfg.wall_viscosity || cfg.wall_artificial_viscosity) {
      BoundaryVelocityKernel<<<boundary_blocks, kBlock, 0, s>>>(grid, bgrid, f, b, c);
    }
  }
  begin_pass();  // interactions
  if (n > 0) {
    InteractionKernel<<<blocks, kBlock, 0, s>>>(
        grid, bgrid, f, b, c, packed, m.density_rate.data(), hydrostatic, gravity, cfg.viscosity,
        cfg.wall_viscosity, cfg.artificial_viscosity, cfg.wall_artificial_viscosity, n);
  }
}

StepMaxima WcsphPipeline::Forces(float gravity, float hydrostatic,
                                 const ObstacleMotionTable& motion) {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  const uint32_t n = m.n;
  cudaStream_t s = m.stream.get();
  const unsigned blocks = (n + kBlock - 1) / kBlock;
  m.pass = 0;
  m.ForcePasses(gravity, hydrostatic, motion);
  m.timer.Record(m.pass++, s);  // time_step: the maxima here, the step on the host (CflLimits)
  StepMaxima result;
  if (n > 0) {
    const Fluid f = m.View();
    const float* density = m.density.data();
    if (m.owned_host.empty()) {
      MaximaInputsKernel<<<blocks, kBlock, 0, s>>>(f, m.speed2.data(), m.acceleration2.data(), n);
    } else {
      m.owned_density.Resize(n);
      OwnedMaximaInputsKernel<<<blocks, kBlock, 0, s>>>(
          f, m.sorter.View(), m.owned_layers.data(), m.owned_axis, m.speed2.data(),
          m.acceleration2.data(), m.owned_density.data(), n);
      density = m.owned_density.data();
    }
    m.Max(m.speed2.data(), m.device_maxima.data());
    m.Max(m.acceleration2.data(), m.device_maxima.data() + 1);
    m.Max(density, m.device_maxima.data() + 2);
    m.maxima.CopyFrom(m.device_maxima, 3, s);
    CheckCuda(cudaGetLastError(), "launching the wcsph forces");
    CheckCuda(cudaStreamSynchronize(s), "running the wcsph forces");
    // The CPU's maxima start at 0 (reduction(max) over values that are all >= 0).
    result.speed2 = m.maxima.data()[0] > 0 ? m.maxima.data()[0] : 0.0f;
    result.acceleration2 = m.maxima.data()[1] > 0 ? m.maxima.data()[1] : 0.0f;
    result.density = m.maxima.data()[2] > 0 ? m.maxima.data()[2] : 0.0f;
  } else {
    // No particles here (a process's empty slab): the sort's cell maximum, which the caller
    // reads next, is copied once the stream has passed it.
    CheckCuda(cudaStreamSynchronize(s), "running the wcsph forces");
  }
  return result;
}

StepOutcome WcsphPipeline::Integrate(float dt) {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  const uint32_t n = m.n;
  cudaStream_t s = m.stream.get();
  const unsigned blocks = (n + kBlock - 1) / kBlock;
  const Shift shift = m.ShiftingPass();
  m.timer.Record(m.pass++, s);  // integrate
  CheckCuda(cudaMemsetAsync(m.device_flags.data(), 0, 2 * sizeof(unsigned long long), s),
            "clearing the step's flags");
  if (n > 0) {
    IntegrateKernel<<<blocks, kBlock, 0, s>>>(m.View(), m.config.constants, m.SurfaceView(),
                                              m.carried.data(), m.density_rate.data(), shift, dt,
                                              n);
  }
  return m.FinishStep("the wcsph integration");
}

Shift WcsphPipeline::Impl::ShiftingPass() {
  if (!(config.shifting > 0)) return {};
  cudaStream_t s = stream.get();
  timer.Record(pass++, s);  // shifting
  for (DeviceBuffer<float>* b : {&shift_x, &shift_y, &shift_z}) b->Resize(n > 0 ? n : 1);
  if (n > 0) {
    ParticleShiftingKernel<<<(n + kBlock - 1) / kBlock, kBlock, 0, s>>>(
        sorter.View(), boundary_sorter.View(), View(), BoundaryView(), config.constants,
        config.shifting, config.free_surface_divergence, shift_x.data(), shift_y.data(),
        shift_z.data(), n);
  }
  return {shift_x.data(), shift_y.data(), shift_z.data()};
}

void WcsphPipeline::Predict(float half) {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  const uint32_t n = m.n;
  cudaStream_t s = m.stream.get();
  m.timer.Record(m.pass++, s);  // predict
  for (DeviceBuffer<float>* b : {&m.start_x, &m.start_y, &m.start_z, &m.start_vx, &m.start_vy,
                                 &m.start_vz, &m.start_density}) {
    b->Resize(n > 0 ? n : 1);
  }
  if (n > 0) {
    PredictKernel<<<(n + kBlock - 1) / kBlock, kBlock, 0, s>>>(
        m.View(), m.config.constants, m.SurfaceView(), m.StartView(), m.carried.data(),
        m.density_rate.data(), half, n);
  }
  m.predicted = true;
  CheckCuda(cudaGetLastError(), "launching the wcsph predictor");
}

void WcsphPipeline::CorrectorForces(float gravity, float hydrostatic,
                                    const ObstacleMotionTable& motion) {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  m.ForcePasses(gravity, hydrostatic, motion);
  CheckCuda(cudaGetLastError(), "launching the wcsph corrector's forces");
}

StepOutcome WcsphPipeline::Correct(float dt) {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  const uint32_t n = m.n;
  cudaStream_t s = m.stream.get();
  const Shift shift = m.ShiftingPass();
  m.timer.Record(m.pass++, s);  // correct
  CheckCuda(cudaMemsetAsync(m.device_flags.data(), 0, 2 * sizeof(unsigned long long), s),
            "clearing the step's flags");
  if (n > 0) {
    CorrectKernel<<<(n + kBlock - 1) / kBlock, kBlock, 0, s>>>(
        m.View(), m.config.constants, m.SurfaceView(), m.StartView(), m.carried.data(),
        m.density_rate.data(), shift, dt, n);
  }
  m.predicted = false;
  return m.FinishStep("the wcsph correction");
}

uint64_t WcsphPipeline::DeviceBytes() const {
  const Impl& m = *impl_;
  // Wcsph's own: 4 float arrays per particle (p / rho^2, the carried density, its scratch, its
  // rate), the packed sweep state, and 2 per boundary sample (its pressures).
  return m.PhysicalDeviceBytes() + uint64_t(m.x.capacity()) * 4 * sizeof(float) +
         uint64_t(m.packed_position.capacity()) * 2 * sizeof(float4) +
         uint64_t(m.bx.capacity()) * 2 * sizeof(float) + m.reduce_temp.capacity();
}

}  // namespace dysa::cuda
