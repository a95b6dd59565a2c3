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
    if (backend_->DownloadByIds(ids, position, velocity, density)) return ids.size();
  }
  const auto* gpu = dynamic_cast<const GpuBackend*>(backend_.get());
  if (gpu && host_stale_) {
    // No device gather by id yet: every asked array comes to the host, then the ids' entries.
    std::vector<float> p(position ? 3 * n : 0), v(velocity ? 3 * n : 0), d(density ? n : 0);
    ReadParticlesById({p, v, d});
    for (const uint32_t k : ids) {
      for (int a = 0; a < 3; ++a) {
        if (position) position[3 * size_t(k) + a] = p[3 * size_t(k) + a];
        if (velocity) velocity[3 * size_t(k) + a] = v[3 * size_t(k) + a];
      }
      if (density) density[k] = d[k];
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

// The same reduction as the codec's WidenPositionsToAll over a full read (min and max of floats
// are exact and skip a NaN the same way in any order), so a keyframe quantised over these bounds
// has the bits of one quantised over every particle. `xyz`: n consecutive triples of floats.
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
    b.lo[a] = mn;
    b.hi[a] = mx;
  }
  return b;
}

}  // namespace

Simulation::PositionBounds Simulation::ReadPositionBounds() const {
  const size_t n = particle_count_;
  if (backend_ && host_stale_) {
    // Reduced where the particles live (the ranks: 6 values each).
    PositionBounds b;
    if (backend_->DownloadPositionBounds(b.lo, b.hi)) return b;
  }
  const auto* gpu = dynamic_cast<const GpuBackend*>(backend_.get());
  if (gpu && host_stale_) {
    // No device reduction wired yet: the positions come to the host (not the host copy).
    std::vector<float> p(3 * n);
    ReadParticlesById({p, {}, {}});
    return BoundsOf(p.data(), n);
  }
  // Vec3 is three packed floats (Real = float): the storage is n triples.
  static_assert(sizeof(Vec3) == 3 * sizeof(float));
  const ParticleArrays& s = state().particles;
  return BoundsOf(n == 0 ? nullptr : s.position[0].data(), n);
}

}  // namespace dysa
