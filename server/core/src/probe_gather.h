// Probes in two stages, the same on every device (probes.h says what each probe measures):
//
//   1. the gather reads each particle once, in parallel: the reductions over all particles
//      (front, density, kinetic energy, counts) and, for each probe that looks at a neighbourhood
//      (height, pressure, wall pressure), the few particles inside a box around its point;
//   2. the finish, on the host, computes each probe from those particles alone.
//
// On a GPU the gather runs on the device and only the reductions' partial sums and the gathered
// particles cross to the host (a few kB), not the state. The finish visits the gathered
// particles in storage order, as a loop over all of them would, so a local probe reads the same
// value from a gather on the CPU, on the GPU and from a full scan, bit for bit. The sums over all
// particles are taken in fixed chunks and then in chunk order: the same for any thread count on
// one device, within rounding (about 1e-15 relative) across devices.
//
// Why not read the neighbour grid's cells instead: the grid describes the positions at the
// step's sort, before the step moved them, so a query through it would need a fresh sort (on
// the GPU the neighbour_grid pass costs more than this gather) or a bound on how far particles
// moved. The gather's test is a few comparisons per particle and windows, at memory speed.
//
// Plain types only (no Eigen, no CUDA): the CUDA gather (cuda/probe_gather.cuh) reads them too.
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

namespace dysa {

// A box around a local probe's point: a particle is gathered when |d_a| <= half[a] on every axis,
// d = x - center taken to the nearest image along periodic axes. half[a] may be infinite.
struct ProbeWindow {
  double center[3] = {0, 0, 0};  // m
  double half[3] = {0, 0, 0};    // m
};

// An axis-aligned region whose particles a count probe counts (bounds included), as Aabb.
struct ProbeBox {
  double lo[3] = {0, 0, 0};  // m
  double hi[3] = {0, 0, 0};  // m
};

// The domain's periodic axes, for the nearest image.
struct ProbeWrap {
  bool periodic[3] = {false, false, false};
  double period[3] = {0, 0, 0};  // m, the domain's length along each periodic axis
};

struct ProbeGatherPlan {
  std::vector<ProbeWindow> windows;   // one per local probe, in probe order
  std::vector<ProbeBox> count_boxes;  // one per count probe, in probe order
  ProbeWrap wrap;
  bool density = false;         // sum and max of the densities
  bool kinetic_energy = false;  // sum of |v|^2
};

// What a local probe's finish reads of a particle.
struct ProbeCandidate {
  uint32_t index = 0;         // storage index: the finish visits candidates in this order
  float x = 0, y = 0, z = 0;  // m
  float pressure = 0;         // Pa
  float density = 0;          // kg/m^3
};

struct ProbeReductions {
  uint64_t particles = 0;
  // The largest coordinate along each axis (a NaN coordinate is skipped, as std::max skips it).
  double front[3] = {-std::numeric_limits<double>::infinity(),
                     -std::numeric_limits<double>::infinity(),
                     -std::numeric_limits<double>::infinity()};
  double density_sum = 0;      // kg/m^3
  double density_max = 0;      // kg/m^3, at least 0
  double speed2_sum = 0;       // (m/s)^2, sum of |v|^2
  std::vector<double> counts;  // per count box
};

struct ProbeGather {
  ProbeReductions reductions;
  std::vector<std::vector<ProbeCandidate>> candidates;  // per window, ascending index
};

// Particles per chunk of the sums: fixed, so that the sums do not depend on the thread count.
inline constexpr uint32_t kProbeChunk = 1u << 14;

// Whether `p` (x, y, z) lies in `window` (through the nearest image along periodic axes, as
// Model::MinimumImage): the one test the CPU and the GPU gathers apply, in double as the finish
// measures.
#if defined(__CUDACC__)
__host__ __device__
#endif
    inline bool
    InProbeWindow(const ProbeWrap& wrap, const ProbeWindow& window, const float* p) {
  for (int a = 0; a < 3; ++a) {
    double d = double(p[a]) - window.center[a];
    if (wrap.periodic[a]) {
      if (d > wrap.period[a] / 2) d -= wrap.period[a];
      if (d < -wrap.period[a] / 2) d += wrap.period[a];
    }
    if (!(d <= window.half[a] && d >= -window.half[a])) return false;
  }
  return true;
}

}  // namespace dysa
