// DistributedSimulation's side of the device's ghost refresh (ProcessShare::device_ghosts,
// dysa/core/device_ghost_exchange.h): for dfsph on GPU ranks, the plan the CPU path makes from
// the host's grid after its sort (AfterSort), made here from the cells of the device's sort, and
// the same GhostRefresh replayed on the values the device reads back. Defined in
// distributed_device_step.cc.
#pragma once

#include <span>
#include <vector>

#include "dysa/core/device_ghost_exchange.h"
#include "dysa/distributed/distributed_simulation.h"

namespace dysa::distributed {

class DistributedSimulation::DeviceGhosts final : public DeviceGhostExchange {
 public:
  explicit DeviceGhosts(DistributedSimulation& sim) : sim_(sim) {}
  // Each particle's layer from its cell, its ghost flag (its distance from this slab, as
  // AfterSort sets it), then GhostRefresh::Plan with the ids: collective, and its check that the
  // processes hold the shared layers' particles in the same order.
  Plan PlanAfterSort(std::span<const uint32_t> id, std::span<const uint32_t> cell) override;
  // GhostRefresh::Exchange; its bytes counted as sent, its wait as a collective's.
  void Exchange(std::span<const Vec3> sent, std::span<Vec3> received) override;

 private:
  DistributedSimulation& sim_;
  std::vector<int> layer_;  // per held particle, its slab-axis layer (scratch)
};

}  // namespace dysa::distributed
