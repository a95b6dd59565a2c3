// Scenes and options the SimulationHost tests share (simulation_host_test.cc,
// simulation_host_gather_test.cc).
#pragma once

#include "dysa/core/params.h"
#include "dysa/core/scene.h"
#include "dysa/service/simulation_host.h"

namespace dysa::service {

// The thesis scene with particle_quantity^3 particles (1,000 at 10).
inline Scene SmallScene(int particle_quantity = 10) {
  Scene scene = LoadScene("seed_basic");
  SetParam(scene.params, "particle_quantity", particle_quantity);
  SetParam(scene.params, "spawn_size", 1.2);
  return scene;
}

inline HostOptions Paused() {
  HostOptions o;
  o.start_paused = true;
  o.frame_rate = 0;  // as fast as possible when running
  return o;
}

}  // namespace dysa::service
