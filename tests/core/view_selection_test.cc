// The host's view subset (server/core/src/view_selection.cc): ViewKeys orders candidates by key
// then id (ties to the smaller id), so selections nest and a budget past the candidates takes
// them all; it asks the weigher once, with each cell's candidate count, also without particles.
// And Simulation::ReadViewSubset on the CPU: the service's ViewOrder's ids with the bits of a
// full read (support/view_subset_check.h; the GPU's side is tests/core/cuda/view_subset_test.cc),
// and clear errors for a request without a weigher or a span of the wrong size.
#include "dysa/core/view_selection.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "dysa/service/view_detail.h"
#include "support/gpu_test.h"
#include "support/view_subset_check.h"

namespace dysa {
namespace {

// One weight for every cell: every key is rank / 2^32 / w.
ViewSubsetRequest Uniform(double w, uint32_t stride, int* calls = nullptr,
                          std::vector<uint32_t>* counts = nullptr) {
  ViewSubsetRequest r;
  r.box_min = {0, 0, 0};
  r.box_max = {1, 1, 1};
  r.stride = stride;
  r.weigh = [=](const ViewGrid&, const uint32_t* count, double* weight) {
    if (calls) ++*calls;
    if (counts) counts->assign(count, count + kViewCells);
    std::fill(weight, weight + kViewCells, w);
  };
  return r;
}

TEST(ViewKeys, TiesGoToTheSmallerIdAndSelectionsNest) {
  // A huge weight rounds every key to 0: all keys tie.
  const size_t n = 1000;
  std::vector<float> p(3 * n, 0.5f);
  const ViewKeys keys(p.data(), n, Uniform(1e300, 1));
  const std::vector<uint32_t> ten = keys.Select(10);
  std::vector<uint32_t> first(10);
  std::iota(first.begin(), first.end(), 0u);
  EXPECT_EQ(ten, first) << "all keys 0: the smallest ids";
  const ViewKeys spread(p.data(), n, Uniform(1, 3));
  EXPECT_EQ(spread.candidates(), 334u);
  std::vector<uint32_t> previous;
  for (uint64_t b : {0, 1, 50, 333, 334, 1000}) {
    const std::vector<uint32_t> s = spread.Select(b);
    EXPECT_EQ(s.size(), std::min<uint64_t>(b, 334));
    EXPECT_TRUE(std::is_sorted(s.begin(), s.end()));
    EXPECT_TRUE(std::includes(s.begin(), s.end(), previous.begin(), previous.end()));
    for (uint32_t id : s) EXPECT_EQ(id % 3, 0u);
    previous = s;
  }
}

TEST(ViewKeys, TheWeigherSeesEachCellsCandidatesOnceAlsoWithoutParticles) {
  int calls = 0;
  std::vector<uint32_t> counts;
  const std::vector<float> p = {0.01f, 0.01f, 0.01f, 0.99f, 0.99f, 0.99f, 0.02f, 0.02f, 0.02f};
  ViewKeys keys(p.data(), 3, Uniform(1, 1, &calls, &counts));
  EXPECT_EQ(calls, 1);
  ASSERT_EQ(counts.size(), kViewCells);
  EXPECT_EQ(counts[0], 2u);
  EXPECT_EQ(counts[kViewCells - 1], 1u);
  EXPECT_EQ(keys.cell_of(1), kViewCells - 1);
  ViewKeys none(nullptr, 0, Uniform(1, 1, &calls, &counts));
  EXPECT_EQ(calls, 2);
  EXPECT_EQ(none.candidates(), 0u);
  EXPECT_TRUE(none.Select(5).empty());
}

// On the CPU the simulation's subset is ViewOrder's, for a physical solver and the seed.
TEST(ViewSubsetCpu, TheSimulationChoosesViewOrdersSelection) {
  Scene seed = LoadScene("seed_basic");
  SetParam(seed.params, "particle_quantity", 10);
  for (const Scene& scene : {testing::DamScene("wcsph"), seed}) {
    Simulation sim(scene);
    for (int i = 0; i < 3; ++i) sim.Step();
    const auto [lo, hi] = testing::DomainOf(sim);
    service::StreamView view;
    view.eye = {lo[0] - 1, hi[1], hi[2] + 1};
    view.target = {lo[0], lo[1], lo[2]};
    view.fov_y_deg = 20;
    const uint64_t n = sim.particle_count();
    for (uint32_t stride : {1u, 4u}) {
      for (uint64_t budget : {uint64_t(0), n / 5, n}) {
        testing::ExpectViewSubsetIsViewOrders(sim, view, lo, hi, stride, budget);
      }
    }
  }
}

TEST(ViewSubsetCpu, ARequestWithoutAWeigherOrASpanOfTheWrongSizeIsRefused) {
  Simulation sim(testing::DamScene("wcsph"));
  std::vector<uint32_t> ids;
  std::vector<float> position(3 * sim.particle_count());
  ViewSubsetRequest request;
  request.box_max = {1, 1, 1};
  const auto message = [&](const ViewSubsetRequest& r, std::vector<float>& p) -> std::string {
    try {
      sim.ReadViewSubset(r, 10, ids, {p, {}, {}});
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "accepted";
  };
  EXPECT_EQ(message(request, position), "ReadViewSubset: the request has no weigher");
  std::vector<float> short_span(7);
  EXPECT_EQ(message(Uniform(1, 1), short_span),
            "ReadViewSubset: position holds 7 floats, not " + std::to_string(position.size()));
  EXPECT_EQ(message(Uniform(1, 1), position), "accepted");
  EXPECT_EQ(ids.size(), 10u);
}

}  // namespace
}  // namespace dysa
