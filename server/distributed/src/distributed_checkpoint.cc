// DistributedSimulation's whole-state views: the particles gathered on process 0 (probes,
// frames, the hash) and checkpoints that restore on any number of processes. Each puts the
// particles into the order key's order, which is the storage order one process would have, so
// that all of them equal what dysa::Simulation gives for the same state.
#include <cstring>
#include <stdexcept>
#include <string>
#include <utility>

#include "dysa/detail_rank.h"
#include "dysa/distributed/distributed_simulation.h"

namespace dysa::distributed {

LocalParticles DistributedSimulation::GatherAll(bool with_arrays, uint32_t threshold) const {
  const ParticleArrays& p = state_.particles;
  const size_t n = p.size();
  // The particles that go: all, or those of BelowRank (a level of detail, chosen where they live).
  std::vector<size_t> chosen;
  chosen.reserve(threshold ? 0 : n);
  for (size_t i = 0; i < n; ++i) {
    if (threshold == 0 || BelowRank(p.id[i], threshold)) chosen.push_back(i);
  }
  // The solver's arrays that every process holds for each of its particles (one none holds,
  // wcsph's carried density before the first step, is gathered empty, as Simulation saves it).
  std::vector<SolverArray> arrays =
      with_arrays ? solver_->SaveArrays() : std::vector<SolverArray>{};
  std::vector<double> missing(arrays.size());
  for (size_t k = 0; k < arrays.size(); ++k) missing[k] = arrays[k].values.size() != n ? 1 : 0;
  comm_.MaxInPlace(missing);
  std::vector<size_t> carried;
  for (size_t k = 0; k < arrays.size(); ++k) {
    if (missing[k] == 0) carried.push_back(k);
  }
  // Per particle: order key, id, position, velocity, density, pressure, then the carried arrays.
  constexpr size_t kFixed = sizeof(uint64_t) + sizeof(uint32_t) + 8 * sizeof(Real);
  const size_t stride = kFixed + carried.size() * sizeof(Real);
  Bytes mine(chosen.size() * stride);
  for (size_t j = 0; j < chosen.size(); ++j) {
    const size_t i = chosen[j];
    std::byte* at = mine.data() + j * stride;
    std::memcpy(at, &keys_[i], 8);
    std::memcpy(at + 8, &p.id[i], 4);
    std::memcpy(at + 12, p.position[i].data(), 3 * sizeof(Real));
    std::memcpy(at + 24, p.velocity[i].data(), 3 * sizeof(Real));
    std::memcpy(at + 36, &p.density[i], sizeof(Real));
    std::memcpy(at + 40, &p.pressure[i], sizeof(Real));
    for (size_t c = 0; c < carried.size(); ++c) {
      std::memcpy(at + kFixed + c * sizeof(Real), &arrays[carried[c]].values[i], sizeof(Real));
    }
  }
  const std::vector<Bytes> parts = comm_.GatherToRoot(mine);
  LocalParticles all;
  for (const SolverArray& a : arrays) all.arrays.push_back({a.name, {}});
  if (comm_.rank() != 0) return all;
  ParticleArrays& w = all.particles;
  for (const Bytes& part : parts) {
    for (size_t at = 0; at + stride <= part.size(); at += stride) {
      const std::byte* from = part.data() + at;
      uint64_t key;
      uint32_t id;
      Vec3 x, v;
      Real density, pressure;
      std::memcpy(&key, from, 8);
      std::memcpy(&id, from + 8, 4);
      std::memcpy(x.data(), from + 12, 3 * sizeof(Real));
      std::memcpy(v.data(), from + 24, 3 * sizeof(Real));
      std::memcpy(&density, from + 36, sizeof(Real));
      std::memcpy(&pressure, from + 40, sizeof(Real));
      all.key.push_back(key);
      w.id.push_back(id);
      w.position.push_back(x);
      w.velocity.push_back(v);
      w.density.push_back(density);
      w.pressure.push_back(pressure);
      for (size_t c = 0; c < carried.size(); ++c) {
        Real value;
        std::memcpy(&value, from + kFixed + c * sizeof(Real), sizeof(Real));
        all.arrays[carried[c]].values.push_back(value);
      }
    }
  }
  SortByKey(all);
  return all;
}

ParticleArrays DistributedSimulation::GatherParticles() const {
  return std::move(GatherAll(false).particles);
}

ParticleArrays DistributedSimulation::GatherParticlesBelowRank(uint32_t threshold) const {
  if (threshold == 0) throw std::invalid_argument("GatherParticlesBelowRank: threshold 0");
  return std::move(GatherAll(false, threshold).particles);
}

uint64_t DistributedSimulation::GlobalStateHash() const {
  State whole;
  whole.particles = GatherParticles();
  return comm_.rank() == 0 ? StateHash(whole) : 0;
}

Checkpoint DistributedSimulation::SaveCheckpoint() const {
  LocalParticles all = GatherAll(true);
  Checkpoint checkpoint;
  if (comm_.rank() != 0) return checkpoint;
  checkpoint.params = model_.params;
  checkpoint.time = state_.time;
  checkpoint.step = state_.step;
  checkpoint.frame = state_.frame;
  checkpoint.id = std::move(all.particles.id);
  checkpoint.position = std::move(all.particles.position);
  checkpoint.velocity = std::move(all.particles.velocity);
  checkpoint.solver_arrays = std::move(all.arrays);
  return checkpoint;
}

void DistributedSimulation::RestoreCheckpoint(const Checkpoint& checkpoint) {
  Configure(checkpoint.params);
  alarm_.clear();
  state_.warning.clear();
  ParticleArrays all;
  all.Resize(checkpoint.id.size());
  all.id = checkpoint.id;
  all.position = checkpoint.position;
  all.velocity = checkpoint.velocity;
  state_.time = checkpoint.time;
  state_.step = checkpoint.step;
  state_.frame = checkpoint.frame;
  Adopt(std::move(all), checkpoint.solver_arrays);
}

}  // namespace dysa::distributed
