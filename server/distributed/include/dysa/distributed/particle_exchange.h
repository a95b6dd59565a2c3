// The particles of one process and their exchange between processes (migration and ghosts).
//
// The order key. A single process sorts its particles into the neighbour grid each step with a
// stable counting sort of the previous step's order, so within a cell particles keep the order
// of the previous step, which kept that of the one before, back to the spawn order. A particle's
// place in that order is (cell, slot): its cell at the latest sort and its rank within that
// cell. Every process knows it for the particles it owns, because it owns whole cells; so
// sorting a process's particles by that key and then stably by cell gives, in every cell, the
// order one process would have, whatever the decomposition, however the particles arrived.
// The neighbour loops then meet the same operands in the same order: the same bits. Before the
// first step the key is the spawn index. This keeps the single-process order (and its golden
// hashes) as it was, where a (cell, id) order would have changed it.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "dysa/core/solver.h"
#include "dysa/core/state.h"
#include "dysa/distributed/communicator.h"
#include "dysa/distributed/slabs.h"

namespace dysa::distributed {

// Particles with their order keys, ghost flags and the per-particle arrays of the solver
// (Solver::SaveArrays), all in one storage order.
struct LocalParticles {
  ParticleArrays particles;
  std::vector<uint64_t> key;
  std::vector<uint8_t> ghost;
  std::vector<SolverArray> arrays;

  size_t size() const { return particles.size(); }
};

// The key of the particle in sorted slot `slot` of cell `cell` (NeighborGrid::CellIndex).
inline uint64_t OrderKey(uint32_t cell, uint32_t slot) { return uint64_t{cell} << 32 | slot; }

// The order keys of every particle of a state just sorted by `grid` (index k: sorted order).
std::vector<uint64_t> OrderKeys(const NeighborGrid& grid, size_t count);
// The same from the cell (NeighborGrid::CellIndex) of each particle in sorted order (a device's
// sort: StepBackend::DownloadSortedCells).
std::vector<uint64_t> OrderKeys(std::span<const uint32_t> sorted_cells);

// What one exchange moved, for this process.
struct ExchangeCounts {
  uint64_t migrated = 0;     // owned particles sent to their new owner
  uint64_t ghosts_sent = 0;  // copies sent as ghosts
  uint64_t ghosts = 0;       // ghosts received
  uint64_t bytes_sent = 0;
};

// Collective. `owned` are this process's particles (no ghosts), `layer[i]` the slab layer of
// particle i. Each goes to the owner of its layer under `slabs` (staying here when that is this
// process) and a copy to each process that holds its layer as a ghost layer. Returns this
// process's owned and ghost particles in key order, the arrays named as in `owned.arrays`:
// `owned`'s own storage, the particles that stay compacted in place and the arrivals appended
// (most particles stay; copying each into new arrays cost a third of the exchange).
LocalParticles ExchangeParticles(const Communicator& comm, const Slabs& slabs,
                                 std::span<const int> layer, LocalParticles owned,
                                 ExchangeCounts& counts);

// Puts every array of `particles` that holds one value per particle (density, pressure and the
// solver's arrays; an empty one stays empty) into key order. Keys must be unique: throws
// std::logic_error otherwise.
void SortByKey(LocalParticles& particles);

// Keeps the particles whose `keep` flag is set, in order (all arrays of `arrays` that hold one
// value per particle too).
void KeepParticles(std::span<const uint8_t> keep, ParticleArrays& particles,
                   std::vector<SolverArray>& arrays);

}  // namespace dysa::distributed
