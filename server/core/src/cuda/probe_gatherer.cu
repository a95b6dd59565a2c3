#include <algorithm>
#include <cmath>
#include <cstring>
#include <cub/block/block_reduce.cuh>

#include "cuda/probe_gatherer.cuh"

namespace dysa::cuda {

namespace {

// The most blocks of the gather: enough to fill a GPU, few enough that the partial sums are a
// small copy (1,024 blocks x 6 + boxes doubles).
constexpr uint32_t kMaxBlocks = 1024;

// Each block's partial values, in this order, then one per count box.
enum ReductionSlot : int {
  kFrontX,
  kFrontY,
  kFrontZ,
  kDensitySum,
  kDensityMax,
  kSpeed2Sum,
  kFirstCount
};

// Whether the n values at `a` are the bytes of `uploaded` (what is on the device already).
template <class T>
bool SameBytes(const T* a, size_t n, const std::vector<T>& uploaded) {
  return n == uploaded.size() && (n == 0 || std::memcmp(a, uploaded.data(), n * sizeof(T)) == 0);
}

// std::max's choice: a NaN second argument is skipped.
struct MaxOp {
  __device__ double operator()(double a, double b) const { return a < b ? b : a; }
};

__global__ void GatherKernel(ProbeParticles p, const ProbeWindow* windows, uint32_t window_count,
                             const ProbeBox* boxes, uint32_t box_count, ProbeWrap wrap,
                             bool density, bool kinetic_energy, uint32_t capacity, uint32_t* hits,
                             WindowHit* found, double* partials) {
  using Reduce = cub::BlockReduce<double, kBlock>;
  __shared__ typename Reduce::TempStorage storage;
  const double inf = INFINITY;
  double front[3] = {-inf, -inf, -inf};
  double density_sum = 0, density_max = 0, speed2_sum = 0;
  // Count boxes: at most a few; counted in one register each up to kCountRegisters, beyond that
  // by further passes of the same loop (box_base).
  constexpr uint32_t kCountRegisters = 8;
  double counts[kCountRegisters] = {};
  const uint32_t stride = gridDim.x * blockDim.x;
  for (uint32_t i = blockIdx.x * blockDim.x + threadIdx.x; i < p.n; i += stride) {
    const float x[3] = {p.x[i], p.y[i], p.z[i]};
    for (int a = 0; a < 3; ++a) front[a] = MaxOp()(front[a], double(x[a]));
    if (density) {
      density_sum += double(p.density[i]);
      density_max = MaxOp()(density_max, double(p.density[i]));
    }
    if (kinetic_energy) {
      const double vx = p.vx[i], vy = p.vy[i], vz = p.vz[i];
      speed2_sum += vx * vx + (vy * vy + vz * vz);
    }
    for (uint32_t b = 0; b < box_count && b < kCountRegisters; ++b) {
      bool inside = true;
      for (int a = 0; a < 3; ++a)
        inside = inside && x[a] >= boxes[b].lo[a] && x[a] <= boxes[b].hi[a];
      counts[b] += inside ? 1.0 : 0.0;
    }
    for (uint32_t w = 0; w < window_count; ++w) {
      if (!InProbeWindow(wrap, windows[w], x)) continue;
      // Every window's particles in one buffer, each tagged with its window: one copy brings
      // them all to the host.
      const uint32_t slot = atomicAdd(hits, 1u);
      if (slot < capacity) {
        found[slot] = {w,
                       {i, x[0], x[1], x[2], p.pressure ? p.pressure[i] : 0.0f,
                        p.density ? p.density[i] : 0.0f}};
      }
    }
  }
  const uint32_t values = kFirstCount + min(box_count, kCountRegisters);
  double* out = partials + size_t(blockIdx.x) * values;
  auto store = [&](int slot, double v) {
    if (threadIdx.x == 0) out[slot] = v;
    __syncthreads();  // the next reduction reuses the shared storage
  };
  for (int a = 0; a < 3; ++a) store(kFrontX + a, Reduce(storage).Reduce(front[a], MaxOp()));
  store(kDensitySum, Reduce(storage).Sum(density_sum));
  store(kDensityMax, Reduce(storage).Reduce(density_max, MaxOp()));
  store(kSpeed2Sum, Reduce(storage).Sum(speed2_sum));
  for (uint32_t b = 0; b < box_count && b < kCountRegisters; ++b) {
    store(kFirstCount + int(b), Reduce(storage).Sum(counts[b]));
  }
}

}  // namespace

void ProbeGatherer::Gather(const ProbeParticles& particles, const ProbeGatherPlan& plan,
                           cudaStream_t stream, ProbeGather& out) {
  // More count boxes than the kernel's registers: the rest in further gathers of their own.
  constexpr size_t kBoxesPerPass = 8;
  const uint32_t window_count = uint32_t(plan.windows.size());
  const uint32_t blocks = std::clamp<uint32_t>((particles.n + kBlock - 1) / kBlock, 1u, kMaxBlocks);
  // The windows and boxes go up only when they change (a probe's box stays put while the
  // domain does): each upload waits for the stream.
  if (!SameBytes(plan.windows.data(), plan.windows.size(), windows_uploaded_)) {
    windows_.Assign(plan.windows, stream);
    windows_uploaded_ = plan.windows;
  }
  out.reductions = ProbeReductions{};
  out.reductions.particles = particles.n;
  out.reductions.counts.assign(plan.count_boxes.size(), 0.0);
  out.candidates.assign(window_count, {});
  hits_.Resize(1);
  host_hits_.Resize(1);
  size_t box_begin = 0;
  bool first = true;
  while (first || box_begin < plan.count_boxes.size()) {
    const size_t box_count = std::min(kBoxesPerPass, plan.count_boxes.size() - box_begin);
    // Compared in place: a probe evaluation copies no list when nothing changed.
    const ProbeBox* boxes = plan.count_boxes.data() + box_begin;
    if (!SameBytes(boxes, box_count, boxes_uploaded_)) {
      boxes_uploaded_.assign(boxes, boxes + box_count);
      boxes_.Assign(boxes_uploaded_, stream);
    }
    const size_t values = kFirstCount + box_count;
    partials_.Resize(size_t(blocks) * values);
    host_partials_.Resize(size_t(blocks) * values);
    // Windows only on the first pass. The hits come back with the partial sums, as many as the
    // last gather found and a quarter more (one wait for the stream); more need a second copy,
    // more than the capacity a second gather into a larger buffer.
    const uint32_t windows_now = first ? window_count : 0;
    uint32_t total = 0, copied = 0;
    for (;;) {
      found_.Resize(capacity_);
      host_found_.Resize(capacity_);
      CheckCuda(cudaMemsetAsync(hits_.data(), 0, sizeof(uint32_t), stream),
                "clearing the probes' hit count");
      GatherKernel<<<blocks, kBlock, 0, stream>>>(
          particles, windows_.data(), windows_now, boxes_.data(), uint32_t(box_count), plan.wrap,
          first && plan.density, first && plan.kinetic_energy, capacity_, hits_.data(),
          found_.data(), partials_.data());
      CheckCuda(cudaGetLastError(), "launching the probes' gather");
      host_partials_.CopyFrom(partials_, size_t(blocks) * values, stream);
      host_hits_.CopyFrom(hits_, 1, stream);
      copied = windows_now > 0 ? std::min(capacity_, last_hits_ + last_hits_ / 4 + 64) : 0;
      if (copied > 0) host_found_.CopyFrom(found_, copied, stream);
      CheckCuda(cudaStreamSynchronize(stream), "gathering the probes");
      total = host_hits_.data()[0];
      if (total <= capacity_) break;
      capacity_ = total + total / 4;
    }
    if (windows_now > 0) {
      last_hits_ = total;
      if (total > copied) {
        CheckCuda(
            cudaMemcpyAsync(host_found_.data() + copied, found_.data() + copied,
                            (total - copied) * sizeof(WindowHit), cudaMemcpyDeviceToHost, stream),
            "downloading the probes' particles");
        CheckCuda(cudaStreamSynchronize(stream), "downloading the probes' particles");
      }
      for (uint32_t k = 0; k < total; ++k) {
        const WindowHit& hit = host_found_.data()[k];
        out.candidates[hit.window].push_back(hit.candidate);
      }
      // The atomics appended in no particular order; the finish visits storage order.
      for (std::vector<ProbeCandidate>& list : out.candidates) {
        std::sort(list.begin(), list.end(), [](const ProbeCandidate& a, const ProbeCandidate& b) {
          return a.index < b.index;
        });
      }
    }
    // The partials in block order.
    ProbeReductions& r = out.reductions;
    for (uint32_t b = 0; b < blocks; ++b) {
      const double* v = host_partials_.data() + size_t(b) * values;
      if (first) {
        for (int a = 0; a < 3; ++a) r.front[a] = std::max(r.front[a], v[kFrontX + a]);
        r.density_sum += v[kDensitySum];
        r.density_max = std::max(r.density_max, v[kDensityMax]);
        r.speed2_sum += v[kSpeed2Sum];
      }
      for (size_t k = 0; k < box_count; ++k) r.counts[box_begin + k] += v[kFirstCount + k];
    }
    box_begin += box_count;
    first = false;
  }
}

}  // namespace dysa::cuda
