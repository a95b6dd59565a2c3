// The seed solver's step on the GPU (seed_pipeline.h): its buffers, the neighbour list's
// capacity, and the order of its kernels (seed_kernels.cuh, seed_list_kernels.cuh).
#include <cuda_runtime.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>

#include "cuda/device_buffer.cuh"
#include "cuda/device_grid.cuh"
#include "cuda/particle_buffers.cuh"
#include "cuda/seed_kernels.cuh"
#include "cuda/seed_list_kernels.cuh"
#include "cuda/seed_neighbour_list.cuh"
#include "cuda/seed_pipeline.h"

namespace dysa::cuda {

// The positions, velocities, ids, densities and pressures are ParticleBuffers'; these are the
// seed's own.
struct SeedPipeline::Impl : ParticleBuffers {
  explicit Impl(int device_index) : ParticleBuffers(device_index) {
    // DYSA_CUDA_SEED_LIST=K fixes the neighbour list's capacity at K blocks of 8 candidates per
    // particle (0: no list, the grid kernels only; a small K leaves most particles to them), for
    // tests of the grid kernels and the overflow path.
    if (const char* value = std::getenv("DYSA_CUDA_SEED_LIST")) {
      const unsigned long k = std::strtoul(value, nullptr, 10);
      list_want = uint32_t(std::min<unsigned long>(k, kMaxListBlocks));
      list_fixed = true;
    }
  }

  // The neighbour list's capacity, blocks of 8 candidates per particle: the first (2 words per
  // lane, 68 bytes a particle with the units: the ~40-50 blocks of the thesis fluid's 10M and
  // 100M blocks) and the most it grows to (132 bytes: twice the ~65 blocks of its 1M block).
  static constexpr uint32_t kListBlocks = 2 * kBlocksPerWord;
  static constexpr uint32_t kMaxListBlocks = kMaxListWords * kBlocksPerWord;

  static uint64_t RoundUp(uint64_t x, uint64_t to) { return (x + to - 1) / to * to; }

  SeedStepConfig config;
  std::vector<std::string> passes;
  // The predicted positions and their permutation targets (swapped after each sort).
  DeviceBuffer<float> px, py, pz, px2, py2, pz2;
  DeviceBuffer<float> near_density, near_pressure;
  // The grid's points (px, py, pz), for the neighbour kernels, and kLanes - 1 entries of
  // padding (DensityListKernel loads whole blocks).
  DeviceBuffer<float4> pos4;
  DeviceBuffer<PosValue> pos_value;  // the points with the pressure factors; with the velocities
  DeviceBuffer<uint32_t> list_words;
  DeviceBuffer<uint32_t> list_units;
  uint32_t list_want = kListBlocks;  // the capacity (blocks) the next step asks for
  bool list_fixed = false;           // DYSA_CUDA_SEED_LIST: no growth
  bool list_refused = false;         // no room for list_want; not asked again until Upload
  DeviceBuffer<SphereObstacle> spheres;
  DeviceBuffer<BoxObstacle> boxes;
  // Copied back per step: [0] limited, [1] non-finite, [2] the particles the list could not
  // hold.
  PinnedBuffer<unsigned long long> flags;
  DeviceBuffer<unsigned long long> device_flags;
  EventTimer timer;
  // UsePinnedStaging's buffers: ids, positions and velocities (xyz), densities and pressures.
  bool pinned_staging = false;
  PinnedBuffer<uint32_t> stage_id;
  PinnedBuffer<float> stage_position, stage_velocity, stage_density, stage_pressure;

  Particles View() {
    return {x.data(),  y.data(),  z.data(),  vx.data(), vy.data(),
            vz.data(), px.data(), py.data(), pz.data(), id.data()};
  }

  void Allocate(size_t count) {
    AllocateParticles(count, count,
                      {&px, &py, &pz, &px2, &py2, &pz2, &near_density, &near_pressure});
    pos4.Resize(uint64_t(count) + kLanes - 1);
    CheckCuda(cudaMemsetAsync(pos4.data() + count, 0, (kLanes - 1) * sizeof(float4), stream.get()),
              "clearing the positions' padding");
    pos_value.Resize(count);
    list_units.Resize(count);
  }

  void Sort() {
    const Particles p = View();
    sorter.Sort(config.grid, p.px, p.py, p.pz, n, stream.get());
    const uint32_t* order = sorter.order();
    Gather(order, x, x2, n), Gather(order, y, y2, n), Gather(order, z, z2, n);
    Gather(order, vx, vx2, n), Gather(order, vy, vy2, n), Gather(order, vz, vz2, n);
    if (n > 0) {
      GatherPredictedKernel<<<(n + kBlock - 1) / kBlock, kBlock, 0, stream.get()>>>(
          order, px.data(), py.data(), pz.data(), px2.data(), py2.data(), pz2.data(), pos4.data(),
          n);
    }
    px.swap(px2), py.swap(py2), pz.swap(pz2);
    Gather(order, id, id2, n);
  }

  // Word w of a particle's lane l lies (8 w + l) * ListStride() words after its first; rounded
  // up so that a warp's words start on a 128-byte line.
  uint64_t ListStride() const { return RoundUp(n, 32); }

  // The list for this step (capacity 0 for the grid kernels: periodic axes, as the list does not
  // carry the runs' shifts, or no room). It takes at most half the GPU memory free besides it;
  // without room for list_want, it keeps the words it has.
  NeighbourList PrepareList() {
    NeighbourList list{list_words.data(), list_units.data(), ListStride(), 0, 0};
    const GridLayout& g = config.grid;
    if (n == 0 || list_want == 0 || g.periodic[0] || g.periodic[1] || g.periodic[2] ||
        !(config.constants.h2 > 0)) {
      return list;
    }
    const uint64_t per_word = kLanes * list.stride;  // a word of every lane of every particle
    const uint64_t words = (list_want + kBlocksPerWord - 1) / kBlocksPerWord;
    if (list_words.capacity() < words * per_word && !list_refused) {
      size_t free = 0, total = 0;
      CheckCuda(cudaMemGetInfo(&free, &total), "reading the free GPU memory");
      const uint64_t own = list_words.capacity() * sizeof(uint32_t);
      if (words * per_word * sizeof(uint32_t) <= (free + own) / 2) {
        try {
          list_words.Resize(words * per_word);
        } catch (const std::runtime_error&) {
          cudaGetLastError();  // clears the failed allocation's error: the grid kernels go on
        }
      }
      list_refused = list_words.capacity() < words * per_word;
    }
    list.word = list_words.data();
    list.words = uint32_t(std::min<uint64_t>(words, list_words.capacity() / per_word));
    list.capacity = std::min(list_want, list.words * kBlocksPerWord);
    return list;
  }

  // After a step in which more than one particle in 1,024 did not fit (their pressure force and
  // viscosity take the grid kernels, whose warps cost as much for one such particle as for 32),
  // a word more per lane for the next steps, up to kMaxListBlocks; the rest stay with the grid.
  void GrowList(uint32_t capacity, uint64_t unlisted) {
    if (capacity == 0 || list_fixed || list_refused || unlisted <= n / 1024) return;
    list_want = std::min(uint32_t(RoundUp(capacity + 1, kBlocksPerWord)), kMaxListBlocks);
  }
};

SeedPipeline::SeedPipeline(int device) : impl_(std::make_unique<Impl>(device)) {
  arrays_ = impl_.get();
}
SeedPipeline::~SeedPipeline() = default;

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
  m.flags.Resize(3);
  m.device_flags.Resize(3);
  CheckCuda(cudaStreamSynchronize(m.stream.get()), "configuring the seed step");
  return m.passes;
}

void SeedPipeline::Upload(size_t n, const uint32_t* id, const float* position,
                          const float* velocity) {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  m.Allocate(n);
  m.list_refused = false;
  if (m.pinned_staging && n > 0) {
    // Through the page-locked buffers: a host copy, then a DMA at the bus's speed.
    m.stage_id.Resize(n);
    m.stage_position.Resize(3 * n);
    m.stage_velocity.Resize(3 * n);
    std::memcpy(m.stage_id.data(), id, n * sizeof(uint32_t));
    std::memcpy(m.stage_position.data(), position, 3 * n * sizeof(float));
    std::memcpy(m.stage_velocity.data(), velocity, 3 * n * sizeof(float));
    id = m.stage_id.data();
    position = m.stage_position.data();
    velocity = m.stage_velocity.data();
  }
  m.EnqueueUpload(id, position, velocity);
  // As the densities and pressures (EnqueueUpload), the step's other outputs read zeros before
  // the first step.
  for (DeviceBuffer<float>* b : {&m.px, &m.py, &m.pz, &m.near_density, &m.near_pressure}) {
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
  if (m.pinned_staging && n > 0) {
    // The shared arrays through the page-locked buffers (UsePinnedStaging), the rest directly.
    m.stage_id.Resize(n), m.stage_density.Resize(n), m.stage_pressure.Resize(n);
    m.stage_position.Resize(3 * n), m.stage_velocity.Resize(3 * n);
    m.EnqueueDownload(
        id ? m.stage_id.data() : nullptr, position ? m.stage_position.data() : nullptr,
        velocity ? m.stage_velocity.data() : nullptr, density ? m.stage_density.data() : nullptr,
        pressure ? m.stage_pressure.data() : nullptr);
    CheckCuda(cudaStreamSynchronize(m.stream.get()), "downloading particles");
    if (id) std::memcpy(id, m.stage_id.data(), n * sizeof(uint32_t));
    if (position) std::memcpy(position, m.stage_position.data(), 3 * n * sizeof(float));
    if (velocity) std::memcpy(velocity, m.stage_velocity.data(), 3 * n * sizeof(float));
    if (density) std::memcpy(density, m.stage_density.data(), n * sizeof(float));
    if (pressure) std::memcpy(pressure, m.stage_pressure.data(), n * sizeof(float));
  } else {
    m.EnqueueDownload(id, position, velocity, density, pressure);
  }
  if (predicted) DownloadInterleaved(m.px, m.py, m.pz, n, predicted, m.stream.get());
  if (near_density) m.near_density.CopyTo(near_density, n, m.stream.get());
  if (near_pressure) m.near_pressure.CopyTo(near_pressure, n, m.stream.get());
  CheckCuda(cudaStreamSynchronize(m.stream.get()), "downloading particles");
}

void SeedPipeline::UsePinnedStaging(bool on) { impl_->pinned_staging = on; }

void SeedPipeline::DownloadSortedCells(uint32_t* cells) const {
  Impl& m = *impl_;
  if (m.n == 0) return;
  DeviceScope scope(m.device);
  cudaStream_t s = m.stream.get();
  CheckCuda(cudaMemcpyAsync(cells, m.sorter.View().sorted_key, size_t(m.n) * sizeof(uint32_t),
                            cudaMemcpyDeviceToHost, s),
            "downloading the sorted cells");
  CheckCuda(cudaStreamSynchronize(s), "downloading the sorted cells");
}

void SeedPipeline::MoveObstacles(const std::vector<SphereObstacle>& spheres,
                                 const std::vector<BoxObstacle>& boxes) {
  Impl& m = *impl_;
  DeviceScope scope(m.device);
  m.spheres.Assign(spheres, m.stream.get());
  m.boxes.Assign(boxes, m.stream.get());
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
  CheckCuda(cudaMemsetAsync(m.device_flags.data(), 0, 3 * sizeof(unsigned long long), s),
            "clearing the step's flags");
  auto begin_pass = [&] { m.timer.Record(pass++, s); };
  const NeighbourList list = launch ? m.PrepareList() : NeighbourList{};
  const uint32_t capacity = list.capacity;
  // With a list, the grid kernels compute only the pressure force and viscosity of the particles
  // it could not hold.
  const Overflow overflow{capacity > 0 ? list.units : nullptr};
  const Densities densities{m.density.data(), m.near_density.data(), m.pressure.data(),
                            m.near_pressure.data()};
  const float4* pos = m.pos4.data();
  PosValue* pv = m.pos_value.data();

  begin_pass();  // external_forces
  if (launch) {
    ExternalForcesKernel<<<blocks, kBlock, 0, s>>>(m.View(), n, cfg.gravity_dv, cfg.lookahead);
  }
  begin_pass();  // neighbour_grid
  m.Sort();
  const DeviceGrid grid = m.sorter.View();
  begin_pass();  // density
  if (launch) {
    unsigned long long* unlisted = m.device_flags.data() + 2;
    if (capacity > 0) {
      if (cfg.near) {
        DensityListKernel<true>
            <<<blocks, kBlock, 0, s>>>(grid, pos, list, densities, c, unlisted, n);
      } else {
        DensityListKernel<false>
            <<<blocks, kBlock, 0, s>>>(grid, pos, list, densities, c, unlisted, n);
      }
    } else if (cfg.near) {
      DensityKernel<true><<<blocks, kBlock, 0, s>>>(grid, pos, densities, c, n);
    } else {
      DensityKernel<false><<<blocks, kBlock, 0, s>>>(grid, pos, densities, c, n);
    }
  }
  begin_pass();  // pressure_force
  if (launch) {
    PressureFactorsKernel<<<blocks, kBlock, 0, s>>>(pos, m.density.data(), m.pressure.data(),
                                                    m.near_pressure.data(), pv, n, cfg.near);
    const Particles p = m.View();
    const float* pr = m.pressure.data();
    const float* near_pr = m.near_pressure.data();
    if (cfg.near) {
      if (capacity > 0) {
        PressureForceListKernel<true>
            <<<blocks, kBlock, 0, s>>>(grid, p, pos, pr, near_pr, pv, list, c, n);
      }
      PressureForceKernel<true>
          <<<blocks, kBlock, 0, s>>>(grid, p, pos, pr, near_pr, pv, c, overflow, n);
    } else {
      if (capacity > 0) {
        PressureForceListKernel<false>
            <<<blocks, kBlock, 0, s>>>(grid, p, pos, pr, near_pr, pv, list, c, n);
      }
      PressureForceKernel<false>
          <<<blocks, kBlock, 0, s>>>(grid, p, pos, pr, near_pr, pv, c, overflow, n);
    }
  }
  if (cfg.viscosity) {
    begin_pass();  // viscosity
    if (launch) {
      PackVelocityKernel<<<blocks, kBlock, 0, s>>>(m.View(), pos, pv, n);
      if (capacity > 0) {
        ViscosityListKernel<<<blocks, kBlock, 0, s>>>(grid, m.View(), pos, pv, list, c, n);
      }
      ViscosityKernel<<<blocks, kBlock, 0, s>>>(grid, m.View(), pos, pv, c, overflow, n);
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
  m.flags.CopyFrom(m.device_flags, 3, s);
  CheckCuda(cudaStreamSynchronize(s), "running the seed step");
  m.GrowList(capacity, m.flags.data()[2]);

  StepOutcome outcome;
  outcome.pass_ms = m.timer.ElapsedMs(pass);
  outcome.limited = m.flags.data()[0];
  outcome.finite = m.flags.data()[1] == 0;
  return outcome;
}

uint64_t SeedPipeline::DeviceBytes() const {
  const Impl& m = *impl_;
  // The seed's own: 8 float arrays (the predictions, their permutation targets, the near
  // densities and pressures), the packed positions (float4) and the positions with values (two
  // float4), and the neighbour list's units and words.
  return m.ParticleDeviceBytes() + uint64_t(m.x.capacity()) * 8 * sizeof(float) +
         uint64_t(m.pos4.capacity()) * sizeof(float4) +
         uint64_t(m.pos_value.capacity()) * sizeof(PosValue) +
         uint64_t(m.list_units.capacity() + m.list_words.capacity()) * sizeof(uint32_t);
}

}  // namespace dysa::cuda
