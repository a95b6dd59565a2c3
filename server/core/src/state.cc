#include "dysa/core/state.h"

#include <cstring>

namespace dysa {

void ParticleArrays::Resize(size_t n) {
  id.resize(n);
  position.resize(n);
  velocity.resize(n);
  density.resize(n);
  pressure.resize(n);
}

namespace {

constexpr uint64_t kFnvOffset = 0xcbf29ce484222325ull;
constexpr uint64_t kFnvPrime = 0x100000001b3ull;

void HashBytes(uint64_t& h, const void* data, size_t size) {
  const auto* bytes = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < size; ++i) h = (h ^ bytes[i]) * kFnvPrime;
}

}  // namespace

uint64_t StateHash(const State& state) {
  const ParticleArrays& p = state.particles;
  std::vector<uint32_t> slot_of_id(p.size());
  for (size_t i = 0; i < p.size(); ++i) slot_of_id[p.id[i]] = static_cast<uint32_t>(i);
  uint64_t h = kFnvOffset;
  for (uint32_t slot : slot_of_id) {
    HashBytes(h, &p.id[slot], sizeof(uint32_t));
    HashBytes(h, p.position[slot].data(), 3 * sizeof(Real));
    HashBytes(h, p.velocity[slot].data(), 3 * sizeof(Real));
  }
  return h;
}

bool StateIsFinite(const ParticleArrays& particles) {
  // Branch-free per particle, so the loop vectorises; x - x is NaN exactly when x is not finite.
  int finite = 1;
  const int64_t n = int64_t(particles.size());
#pragma omp parallel for reduction(& : finite) schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    const Vec3& x = particles.position[i];
    const Vec3& v = particles.velocity[i];
    const Real sum = (x.x() - x.x()) + (x.y() - x.y()) + (x.z() - x.z()) + (v.x() - v.x()) +
                     (v.y() - v.y()) + (v.z() - v.z());
    finite &= sum == 0;
  }
  return finite != 0;
}

}  // namespace dysa
