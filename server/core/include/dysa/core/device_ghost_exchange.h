// The hook a device's step (a GPU's StepBackend) calls where its solver refreshes the ghosts of
// one process's share inside the step: dfsph, whose pressure solves iterate on their neighbours'
// velocities (ProcessShare::refresh_ghosts does it on the CPU, over the host's arrays). On a
// device the particles are not in host memory during the step, so the refresh splits in three:
// the device reads back only the values other processes read of it (its owned particles in
// their ghost layers), this hook exchanges them between the processes, and the device writes the
// values that came back into its ghosts. The driver of the processes implements it
// (server/distributed: its GhostRefresh plan, replayed), which keeps core free of MPI.
//
// The pattern is fixed from the neighbour sort to the end of the step (the particles stay where
// the sort put them until the integration), so it is planned once per step, from the device's
// sorted order, and every refresh of the step replays it.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "dysa/core/types.h"

namespace dysa {

class DeviceGhostExchange {
 public:
  // A step's pattern, in the device's storage order (the order of its neighbour sort).
  struct Plan {
    // Per held particle: 0 for an owned particle, else a ghost's distance in cell layers from
    // this process's slab (ProcessShare::ghost). The reductions that steer the step (the
    // solves' mean errors, the CFL maxima, the speed limiter's count) skip the ghosts.
    std::vector<uint8_t> ghost;
    // The owned particles other processes read, by storage index, in the order Exchange takes
    // their values (one entry per reading process: a particle two processes read is listed
    // twice).
    std::vector<uint32_t> sent;
    // The ghosts, by storage index, in the order Exchange returns their owners' values.
    std::vector<uint32_t> received;
  };

  virtual ~DeviceGhostExchange() = default;
  // Collective. After the device's neighbour sort: each held particle's id and cell
  // (NeighborGrid::CellIndex), storage order. Throws std::logic_error when the processes do not
  // hold the particles of their shared layers in the same order.
  virtual Plan PlanAfterSort(std::span<const uint32_t> id, std::span<const uint32_t> cell) = 0;
  // Collective; the plan's sizes. sent[k]: the value of particle plan.sent[k]; received[k]
  // becomes the value that ghost plan.received[k]'s owner sent.
  virtual void Exchange(std::span<const Vec3> sent, std::span<Vec3> received) = 0;
};

}  // namespace dysa
