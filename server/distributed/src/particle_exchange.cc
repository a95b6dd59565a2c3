#include "dysa/distributed/particle_exchange.h"

#include <algorithm>
#include <cstring>
#include <numeric>
#include <stdexcept>
#include <string>

namespace dysa::distributed {
namespace {

// One particle on the wire, followed by one Real per solver array.
struct Record {
  uint64_t key;
  uint32_t id;
  uint32_t ghost;
  Real position[3];
  Real velocity[3];
};
static_assert(sizeof(Record) == 40);

void Append(Bytes& out, const LocalParticles& from, size_t i, bool ghost) {
  Record r;
  r.key = from.key[i];
  r.id = from.particles.id[i];
  r.ghost = ghost ? 1 : 0;
  for (int a = 0; a < 3; ++a) {
    r.position[a] = from.particles.position[i][a];
    r.velocity[a] = from.particles.velocity[i][a];
  }
  const size_t at = out.size();
  out.resize(at + sizeof(Record) + from.arrays.size() * sizeof(Real));
  std::memcpy(out.data() + at, &r, sizeof(Record));
  for (size_t k = 0; k < from.arrays.size(); ++k) {
    std::memcpy(out.data() + at + sizeof(Record) + k * sizeof(Real), &from.arrays[k].values[i],
                sizeof(Real));
  }
}

// Moves particle i of `p` to index `out` <= i (the compaction of the particles that stay).
void MoveDown(LocalParticles& p, size_t i, size_t out, bool ghost) {
  p.ghost[out] = ghost ? 1 : 0;
  if (out == i) return;
  p.particles.id[out] = p.particles.id[i];
  p.particles.position[out] = p.particles.position[i];
  p.particles.velocity[out] = p.particles.velocity[i];
  p.key[out] = p.key[i];
  for (SolverArray& a : p.arrays) a.values[out] = a.values[i];
}

void Unpack(const Bytes& in, LocalParticles& to) {
  const size_t stride = sizeof(Record) + to.arrays.size() * sizeof(Real);
  if (in.size() % stride != 0) throw std::logic_error("ExchangeParticles: a truncated record");
  for (size_t at = 0; at < in.size(); at += stride) {
    Record r;
    std::memcpy(&r, in.data() + at, sizeof(Record));
    to.particles.id.push_back(r.id);
    to.particles.position.emplace_back(r.position[0], r.position[1], r.position[2]);
    to.particles.velocity.emplace_back(r.velocity[0], r.velocity[1], r.velocity[2]);
    to.key.push_back(r.key);
    to.ghost.push_back(uint8_t(r.ghost));
    for (size_t k = 0; k < to.arrays.size(); ++k) {
      Real v;
      std::memcpy(&v, in.data() + at + sizeof(Record) + k * sizeof(Real), sizeof(Real));
      to.arrays[k].values.push_back(v);
    }
  }
}

template <class T>
void Permute(std::span<const size_t> order, std::vector<T>& data) {
  std::vector<T> out(order.size());
  for (size_t k = 0; k < order.size(); ++k) out[k] = data[order[k]];
  data.swap(out);
}

}  // namespace

std::vector<uint64_t> OrderKeys(const NeighborGrid& grid, size_t count) {
  std::vector<uint32_t> cells(count);
  for (size_t k = 0; k < count; ++k) cells[k] = grid.CellIndex(grid.SortedCell(uint32_t(k)));
  return OrderKeys(cells);
}

std::vector<uint64_t> OrderKeys(std::span<const uint32_t> sorted_cells) {
  std::vector<uint64_t> keys(sorted_cells.size());
  uint32_t previous = 0;
  uint32_t slot = 0;
  for (size_t k = 0; k < sorted_cells.size(); ++k) {
    const uint32_t cell = sorted_cells[k];
    slot = k > 0 && cell == previous ? slot + 1 : 0;
    previous = cell;
    keys[k] = OrderKey(cell, slot);
  }
  return keys;
}

LocalParticles ExchangeParticles(const Communicator& comm, const Slabs& slabs,
                                 std::span<const int> layer, LocalParticles owned,
                                 ExchangeCounts& counts) {
  const int me = comm.rank();
  std::vector<Bytes> to(size_t(comm.size()));
  counts = {};
  const size_t n = owned.size();
  owned.ghost.resize(n);
  size_t kept = 0;
  for (size_t i = 0; i < n; ++i) {
    const int owner = slabs.OwnerOf(layer[i]);
    bool stays = owner == me;
    if (!stays) {
      Append(to[owner], owned, i, false);
      ++counts.migrated;
    }
    bool ghost = false;
    for (int reader : slabs.GhostReaders(layer[i])) {
      if (reader == me) {
        stays = ghost = true;
      } else {
        Append(to[reader], owned, i, true);
      }
      ++counts.ghosts_sent;
    }
    // Read above before anything moves onto it: `kept` <= i.
    if (stays) MoveDown(owned, i, kept++, ghost);
  }
  owned.particles.id.resize(kept);
  owned.particles.position.resize(kept);
  owned.particles.velocity.resize(kept);
  owned.key.resize(kept);
  owned.ghost.resize(kept);
  for (SolverArray& a : owned.arrays) a.values.resize(kept);
  for (const Bytes& b : to) counts.bytes_sent += b.size();
  const std::vector<Bytes> from = comm.AllToAll(to);
  for (size_t p = 0; p < from.size(); ++p) {
    if (int(p) != me) Unpack(from[p], owned);
  }
  for (uint8_t g : owned.ghost) counts.ghosts += g;

  // Key order: arrival order must not matter.
  owned.particles.density.assign(owned.size(), Real(0));
  owned.particles.pressure.assign(owned.size(), Real(0));
  SortByKey(owned);
  return owned;
}

void SortByKey(LocalParticles& mine) {
  // The particles a process keeps come first and already in key order (a step keeps the order
  // its sort left, and ExchangeParticles keeps theirs); the arrivals follow. Sorting only what
  // follows the ordered run and merging the two is O(n) for a step's few arrivals, where a full
  // sort of 1 M particles took most of the exchange's 86 ms on one rank (bench/README.md,
  // "Ranks"). A strictly increasing run holds no two equal keys.
  const size_t n = mine.size();
  size_t run = 1;
  while (run < n && mine.key[run - 1] < mine.key[run]) ++run;
  if (run >= n) return;
  std::vector<size_t> order(n);
  std::iota(order.begin(), order.end(), size_t{0});
  const auto by_key = [&](size_t a, size_t b) { return mine.key[a] < mine.key[b]; };
  std::sort(order.begin() + std::ptrdiff_t(run), order.end(), by_key);
  std::inplace_merge(order.begin(), order.begin() + std::ptrdiff_t(run), order.end(), by_key);
  for (size_t k = 1; k < order.size(); ++k) {
    if (mine.key[order[k]] == mine.key[order[k - 1]]) {
      throw std::logic_error("two particles share the order key " +
                             std::to_string(mine.key[order[k]]));
    }
  }
  ParticleArrays& p = mine.particles;
  Permute<uint32_t>(order, p.id);
  Permute<Vec3>(order, p.position);
  Permute<Vec3>(order, p.velocity);
  if (p.density.size() == order.size()) Permute<Real>(order, p.density);
  if (p.pressure.size() == order.size()) Permute<Real>(order, p.pressure);
  Permute<uint64_t>(order, mine.key);
  if (mine.ghost.size() == order.size()) Permute<uint8_t>(order, mine.ghost);
  // An array no process holds yet (wcsph's carried density before the first step) is empty.
  for (SolverArray& a : mine.arrays) {
    if (a.values.size() == order.size()) Permute<Real>(order, a.values);
  }
}

void KeepParticles(std::span<const uint8_t> keep, ParticleArrays& particles,
                   std::vector<SolverArray>& arrays) {
  const size_t n = particles.size();
  size_t out = 0;
  for (size_t i = 0; i < n; ++i) {
    if (!keep[i]) continue;
    particles.id[out] = particles.id[i];
    particles.position[out] = particles.position[i];
    particles.velocity[out] = particles.velocity[i];
    particles.density[out] = particles.density[i];
    particles.pressure[out] = particles.pressure[i];
    for (SolverArray& a : arrays) {
      if (a.values.size() == n) a.values[out] = a.values[i];
    }
    ++out;
  }
  particles.Resize(out);
  for (SolverArray& a : arrays) {
    if (a.values.size() == n) a.values.resize(out);
  }
}

}  // namespace dysa::distributed
