// Refreshing the ghosts from their owners inside a step, for a solver whose passes iterate on
// their neighbours' values (dfsph's pressure solves: each Jacobi iteration reads the velocities
// the previous one wrote, up to max_iterations = 10,000 times a step, so no ghost layer of fixed
// depth computes them locally; distributed_simulation.cc, GhostDepth).
//
// Between the neighbour sort and the end of the step the particles stay where they are, so the
// pattern is fixed for the step: process p sends q the values of its owned particles in the layers
// q holds as ghost layers (Slabs::GhostReaders), in p's storage order; q receives them for its
// ghosts owned by p, in q's storage order. The two orders agree: both processes sorted the same
// particles of those layers into the same cells, and within a cell into their order-key order
// (particle_exchange.h). Plan checks that once per step with the particles' ids.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "dysa/core/types.h"
#include "dysa/distributed/communicator.h"
#include "dysa/distributed/slabs.h"

namespace dysa::distributed {

class GhostRefresh {
 public:
  // Collective. After the neighbour sort: per held particle k (storage order), its slab layer,
  // ghost flag (0: owned; ProcessShare::ghost) and id. Throws std::logic_error when the ids a
  // process would send do not match, one for one, the ghosts another holds.
  void Plan(const Communicator& comm, const Slabs& slabs, std::span<const int> layer,
            std::span<const uint8_t> ghost, std::span<const uint32_t> id);
  // Collective. Every ghost's values[k] becomes its owner's (values: one per held particle, in
  // storage order, as at Plan). Returns the bytes this process sent.
  uint64_t Refresh(const Communicator& comm, std::span<Vec3> values) const;

  // The same pattern for a caller that reads and writes the values itself (a device: only these
  // cross to the host). Sent(): the storage indices of the owned particles whose values go out,
  // process by process in rank order, each process's in storage order; Received(): the ghosts',
  // likewise by owner.
  std::vector<uint32_t> Sent() const;
  std::vector<uint32_t> Received() const;
  // Collective. sent[k] is the value of particle Sent()[k]; received[k] becomes the one the
  // owner of ghost Received()[k] sent. Returns the bytes this process sent. Refresh is this,
  // with the packing from and into `values` around it.
  uint64_t Exchange(const Communicator& comm, std::span<const Vec3> sent,
                    std::span<Vec3> received) const;

 private:
  std::vector<std::vector<uint32_t>> send_;     // per process: the owned particles it reads
  std::vector<std::vector<uint32_t>> receive_;  // per process: the ghosts it owns
};

}  // namespace dysa::distributed
