// The decomposition of the neighbour grid into slabs: each process owns a contiguous range of
// the grid's cell planes (layers) along one axis, so it owns whole cells.
//
// Balance cuts for the particle count: process k's slab starts at the first layer whose
// prefix count reaches k N / P (integers, so every process computes the same cuts from the same
// histogram). A process also holds, as ghosts, the particles of the layers within `depth`
// layers of its slab that other processes own (across the seam of a periodic axis too).
//
// depth is 2 for wcsph, 5 for its predictor-corrector and the seed, 3 for dfsph (GhostDepth in
// distributed_simulation.cc says why): a process then computes every value its own particles
// read, and needs one exchange per step (dfsph, whose solves iterate, also refreshes its ghosts'
// velocities inside the step: ghost_refresh.h).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

namespace dysa::distributed {

class Slabs {
 public:
  // `layers` cell planes along the slab axis shared by `processes` processes (each owns at
  // least one layer; throws std::invalid_argument when layers < processes), periodic or not.
  Slabs(int layers, int processes, bool periodic, int depth);

  // Re-cuts for `counts[l]` particles in layer l (layers() values), balancing the counts.
  void Balance(std::span<const int64_t> counts);
  // Takes `cuts` (processes() + 1 ascending entries from 0 to layers(), each slab at least one
  // layer: std::invalid_argument otherwise), as the step-time balancer chooses (balancer.h).
  void SetCuts(std::span<const int> cuts);

  int layers() const { return layers_; }
  int processes() const { return int(cuts_.size()) - 1; }
  // Process p owns the layers [begin(p), begin(p + 1)).
  int begin(int p) const { return cuts_[p]; }
  std::span<const int> cuts() const { return cuts_; }
  int OwnerOf(int layer) const { return owner_[layer]; }
  // The processes (other than its owner) that hold `layer` as a ghost layer, ascending.
  std::span<const int> GhostReaders(int layer) const { return readers_[layer]; }
  // Layers between `layer` and process p's slab (0 inside it), the short way round a
  // periodic axis.
  int Distance(int layer, int p) const;

 private:
  void Index();

  int layers_;
  bool periodic_;
  int depth_;
  std::vector<int> cuts_;  // processes + 1 entries, cuts_[0] = 0, cuts_.back() = layers
  std::vector<int> owner_;
  std::vector<std::vector<int>> readers_;
};

}  // namespace dysa::distributed
