#include "dysa/service/host_status.h"

#include "dysa/core/simulation.h"
#include "dysa/core/state.h"

namespace dysa::service {

void DescribeSimulation(const Simulation& sim, bool hash, HostStatus& s) {
  // The cheap accessors only, but for the hash (on a GPU, state() copies every particle array).
  s.step = sim.step();
  s.frame = sim.frame();
  s.time = sim.time();
  s.particles = uint32_t(sim.particle_count());
  s.solver = sim.scene().solver;
  s.scene = sim.scene().name;
  for (const PassProfile& prof : sim.profile()) {
    s.passes.push_back(PassStatus{prof.name, prof.last_ms,
                                  prof.calls ? prof.total_ms / double(prof.calls) : 0.0,
                                  prof.calls});
  }
  s.warning = sim.warning();
  s.device = sim.DeviceDescription();
  s.device_memory_bytes = sim.DeviceBytes();
  s.state_hash = hash ? StateHash(sim.state()) : 0;
}

}  // namespace dysa::service
