// The check the CPU and GPU tests of Simulation::ReadViewSubset share: a view subset read
// returns exactly the ids the service's host-side ViewOrder selects on the same state (read in
// full, in id order), writes those particles' entries with the bits of a full read, and nothing
// else.
#pragma once

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "dysa/core/simulation.h"
#include "dysa/service/view_detail.h"

namespace dysa::testing {

inline constexpr float kNotWritten = -1.25e30f;

inline bool SameFloatBits(float a, float b) { return std::memcmp(&a, &b, sizeof(float)) == 0; }

// The simulation's domain box, as GatherSnapshot hands it to the view streams.
inline std::array<std::array<double, 3>, 2> DomainOf(const Simulation& sim) {
  const Aabb& d = sim.model().domain;
  return {{{d.min[0], d.min[1], d.min[2]}, {d.max[0], d.max[1], d.max[2]}}};
}

// Reads the view subset of (view, box, stride, budget) and a full frame: the subset's ids are
// ViewOrder's selection on the full frame's positions, and exactly their entries hold the full
// frame's bits. Returns the ids.
inline std::vector<uint32_t> ExpectViewSubsetIsViewOrders(const Simulation& sim,
                                                          const service::StreamView& view,
                                                          std::array<double, 3> lo,
                                                          std::array<double, 3> hi, uint32_t stride,
                                                          uint64_t budget) {
  const size_t n = sim.particle_count();
  std::vector<float> position(3 * n), velocity(3 * n), density(n);
  sim.ReadParticlesById({position, velocity, density});
  const std::vector<uint32_t> expected =
      service::ViewOrder(view, position, lo, hi, stride).Select(budget);

  std::vector<float> sub_position(3 * n, kNotWritten), sub_velocity(3 * n, kNotWritten),
      sub_density(n, kNotWritten);
  std::vector<uint32_t> ids = {12345};  // replaced
  const size_t count = sim.ReadViewSubset(service::ViewRequest(view, lo, hi, stride), budget, ids,
                                          {sub_position, sub_velocity, sub_density});
  const std::string where = "stride " + std::to_string(stride) + ", budget " +
                            std::to_string(budget) + ", " + std::to_string(n) + " particles";
  EXPECT_EQ(count, ids.size()) << where;
  EXPECT_EQ(ids, expected) << where;
  std::vector<bool> chosen(n, false);
  for (uint32_t id : expected) chosen[id] = true;
  for (size_t k = 0; k < n; ++k) {
    for (int a = 0; a < 3; ++a) {
      const size_t e = 3 * k + size_t(a);
      EXPECT_TRUE(SameFloatBits(sub_position[e], chosen[k] ? position[e] : kNotWritten))
          << "position of id " << k << ", " << where;
      EXPECT_TRUE(SameFloatBits(sub_velocity[e], chosen[k] ? velocity[e] : kNotWritten))
          << "velocity of id " << k << ", " << where;
    }
    EXPECT_TRUE(SameFloatBits(sub_density[k], chosen[k] ? density[k] : kNotWritten))
        << "density of id " << k << ", " << where;
    if (::testing::Test::HasFailure()) break;  // one id's message is enough
  }
  return ids;
}

}  // namespace dysa::testing
