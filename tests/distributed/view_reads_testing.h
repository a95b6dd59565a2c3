// A view stream's reads (Simulation::ReadParticlesByIds, ReadPositionBounds, ReadViewSubset)
// compared between a Simulation on the ranks' backend and a plain one of the same state: the
// ranks_backend_test on one process, mpi_view_reads_test on 2 and 3 ranks.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "dysa/core/simulation.h"
#include "dysa/core/view_selection.h"
#include "dysa/view_key.h"

namespace dysa::distributed {

// A request whose weigher depends on each cell's candidate count (so that the counts must be
// summed over the ranks) and on the cell, and counts its calls.
inline ViewSubsetRequest TestViewRequest(std::array<double, 3> box_min,
                                         std::array<double, 3> box_max, uint32_t stride,
                                         std::shared_ptr<int> calls) {
  ViewSubsetRequest r;
  r.box_min = box_min;
  r.box_max = box_max;
  r.stride = stride;
  r.weigh = [calls](const ViewGrid&, const uint32_t* counts, double* weights) {
    ++*calls;
    for (uint32_t c = 0; c < kViewCells; ++c) {
      if (counts[c] > 0) weights[c] = 1.0 + (c % 5) + 8.0 / counts[c];
    }
  };
  return r;
}

// The test scenes' domain (ranks_dam_break.json), and one degenerate on y and z (the grid
// there spans the particles' bounds).
inline std::vector<std::array<std::array<double, 3>, 2>> TestViewBoxes() {
  return {{{{0, 0, 0}, {0.4, 0.2, 0.04}}}, {{{-0.1, 0.3, 0.02}, {0.5, 0.3, 0.01}}}};
}

// `spread` (on the ranks, its particles there: read straight after a step) and `plain` hold the
// same state: every read gives the same bits and writes the same entries.
inline void ExpectSameViewReads(const Simulation& spread, const Simulation& plain) {
  const size_t n = plain.particle_count();
  ASSERT_EQ(spread.particle_count(), n);
  ASSERT_GT(n, 100u);
  const float kUnwritten = -7;
  // By ids: every 7th, in decreasing order, and the last.
  std::vector<uint32_t> ids;
  for (int64_t k = int64_t(n) - 1; k > 0; k -= 7) ids.push_back(uint32_t(k));
  ids.push_back(0);
  for (const bool all_fields : {true, false}) {
    std::vector<float> p(3 * n, kUnwritten), v(3 * n, kUnwritten), d(n, kUnwritten);
    std::vector<float> q(3 * n, kUnwritten), w(3 * n, kUnwritten), e(n, kUnwritten);
    const Simulation::ParticlesById a{p, all_fields ? std::span<float>(v) : std::span<float>(),
                                      all_fields ? std::span<float>(d) : std::span<float>()};
    const Simulation::ParticlesById b{q, all_fields ? std::span<float>(w) : std::span<float>(),
                                      all_fields ? std::span<float>(e) : std::span<float>()};
    EXPECT_EQ(spread.ReadParticlesByIds(ids, a), ids.size());
    EXPECT_EQ(plain.ReadParticlesByIds(ids, b), ids.size());
    EXPECT_EQ(p, q);
    EXPECT_EQ(v, w);
    EXPECT_EQ(d, e);
    EXPECT_EQ(std::count(p.begin(), p.end(), kUnwritten), std::ptrdiff_t(3 * (n - ids.size())));
  }
  const Simulation::PositionBounds got = spread.ReadPositionBounds();
  const Simulation::PositionBounds want = plain.ReadPositionBounds();
  EXPECT_EQ(got.lo, want.lo);
  EXPECT_EQ(got.hi, want.hi);
  // View subsets: budgets from none to past every candidate, strides 1 and 3.
  for (const auto& box : TestViewBoxes()) {
    for (const uint32_t stride : {1u, 3u}) {
      for (const uint64_t budget : {uint64_t(0), uint64_t(37), uint64_t(n / 5), uint64_t(n)}) {
        auto spread_calls = std::make_shared<int>(0), plain_calls = std::make_shared<int>(0);
        std::vector<float> p(3 * n, kUnwritten), d(n, kUnwritten);
        std::vector<float> q(3 * n, kUnwritten), e(n, kUnwritten);
        std::vector<uint32_t> got_ids, want_ids;
        const size_t got_count = spread.ReadViewSubset(
            TestViewRequest(box[0], box[1], stride, spread_calls), budget, got_ids, {p, {}, d});
        const size_t want_count = plain.ReadViewSubset(
            TestViewRequest(box[0], box[1], stride, plain_calls), budget, want_ids, {q, {}, e});
        SCOPED_TRACE("stride " + std::to_string(stride) + ", budget " + std::to_string(budget));
        EXPECT_EQ(got_count, want_count);
        EXPECT_EQ(got_ids, want_ids);
        EXPECT_EQ(got_ids.size(), std::min<uint64_t>(budget, (n + stride - 1) / stride));
        EXPECT_EQ(p, q);
        EXPECT_EQ(d, e);
        EXPECT_EQ(*spread_calls, 1);
      }
    }
  }
}

}  // namespace dysa::distributed
