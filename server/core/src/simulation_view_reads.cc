// The reads a view stream's frames make between two selections (Simulation::ReadParticlesByIds)
// and what its keyframes' quantisation needs of the particles it does not send
// (Simulation::ReadPositionBounds): with them a watched frame reads what it sends, not every
// particle (docs/server.md, "View-dependent detail").
#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "dysa/core/simulation.h"
#include "gpu_backend.h"

namespace dysa {

size_t Simulation::ReadParticlesByIds(std::span<const uint32_t> ids,
                                      const ParticlesById& out) const {
  const size_t n = particle_count_;
  const auto check = [&](std::span<float> span, size_t size, const char* what) {
    if (!span.empty() && span.size() != size) {
      throw std::invalid_argument(std::string("ReadParticlesByIds: ") + what + " holds " +
                                  std::to_string(span.size()) + " floats, not " +
                                  std::to_string(size));
    }
    return span.empty() ? nullptr : span.data();
  };
  float* position = check(out.position, 3 * n, "position");
  float* velocity = check(out.velocity, 3 * n, "velocity");
  float* density = check(out.density, n, "density");
  for (const uint32_t id : ids) {
    if (id >= n) {
      throw std::out_of_range("ReadParticlesByIds: id " + std::to_string(id) + " of " +
                              std::to_string(n) + " particles");
    }
  }
  if (ids.empty() || (!position && !velocity && !density)) return ids.size();
  if (backend_ && host_stale_) {
    // Where the particles live (the ranks: each sends only its asked particles).
    if (backend_->GatherByIds(ids, position, velocity, density)) return ids.size();
  }
  const auto* gpu = dynamic_cast<const GpuBackend*>(backend_.get());
  if (gpu && host_stale_) {
    // Gathered and packed in the list's order on the device (only the ids' values cross, with
    // the ids going up); scattered to the ids' entries here.
    const RankSubsetCopy c = gpu->DownloadByIds(ids.data(), ids.size(), position != nullptr,
                                                velocity != nullptr, density != nullptr);
#pragma omp parallel for schedule(static)
    for (size_t j = 0; j < c.count; ++j) {
      const size_t k = c.ids[j];
      for (int a = 0; a < 3; ++a) {
        if (position) position[3 * k + a] = c.position[3 * j + a];
        if (velocity) velocity[3 * k + a] = c.velocity[3 * j + a];
      }
      if (density) density[k] = c.density[j];
    }
    return ids.size();
  }
  // Which ids are asked for, by id: the storage is in cell order, so the scan below finds each
  // asked particle where it lies without an inverse permutation (which would cost a write per
  // particle, as much as the scan).
  std::vector<uint8_t> wanted(n, 0);
  for (const uint32_t id : ids) wanted[id] = 1;
  const ParticleArrays& s = state().particles;
#pragma omp parallel for schedule(static)
  for (size_t i = 0; i < n; ++i) {
    const size_t k = s.id[i];
    if (!wanted[k]) continue;
    for (int a = 0; a < 3; ++a) {
      if (position) position[3 * k + a] = s.position[i][a];
      if (velocity) velocity[3 * k + a] = s.velocity[i][a];
    }
    if (density) density[k] = s.density[i];
  }
  return ids.size();
}

namespace {

// The same reduction as the codec's WidenPositionsToAll over a full read: min and max of floats
// are exact and skip a NaN the same way in any order. Only the sign of a zero extreme depends on
// the order (std::min and std::max keep the first of equal values, and -0 == +0): it is taken
// from the first zero in storage order, so the result is a sequential scan's of the storage
// whatever the threads, and the GPU's (cuda/view_reads.cuh). A keyframe quantised over these
// bounds has the bits of one quantised over every particle. `xyz`: n consecutive triples of
// floats.
Simulation::PositionBounds BoundsOf(const float* xyz, size_t n) {
  Simulation::PositionBounds b;
  for (int a = 0; a < 3; ++a) {
    float mn = std::numeric_limits<float>::infinity();
    float mx = -std::numeric_limits<float>::infinity();
#pragma omp parallel for reduction(min : mn) reduction(max : mx) schedule(static)
    for (size_t i = 0; i < n; ++i) {
      mn = std::min(mn, xyz[3 * i + a]);
      mx = std::max(mx, xyz[3 * i + a]);
    }
    if (mn == 0 || mx == 0) {
      size_t i = 0;
      while (xyz[3 * i + a] != 0) ++i;  // a zero extreme: some coordinate is zero
      const float first_zero = xyz[3 * i + a];
      if (mn == 0) mn = first_zero;
      if (mx == 0) mx = first_zero;
    }
    b.lo[a] = mn;
    b.hi[a] = mx;
  }
  return b;
}

}  // namespace

Simulation::PositionBounds Simulation::ReadPositionBounds() const {
  const size_t n = particle_count_;
  if (backend_ && host_stale_) {
    // Reduced where the particles live (the ranks: 60 bytes each).
    PositionBounds b;
    if (backend_->ReducePositionBounds(b.lo, b.hi)) return b;
  }
  const auto* gpu = dynamic_cast<const GpuBackend*>(backend_.get());
  if (gpu && host_stale_) {
    // Reduced on the device: 24 bytes cross, not the positions.
    PositionBounds b;
    gpu->DownloadPositionBounds(b.lo.data(), b.hi.data());
    return b;
  }
  // Vec3 is three packed floats (Real = float): the storage is n triples.
  static_assert(sizeof(Vec3) == 3 * sizeof(float));
  const ParticleArrays& s = state().particles;
  return BoundsOf(n == 0 ? nullptr : s.position[0].data(), n);
}

}  // namespace dysa
