// Tests of a view stream's subset chosen on the GPU (server/core/src/cuda/view_subset.cu)
// through Simulation::ReadViewSubset, for the three solvers' CUDA backends: the device returns
// exactly the ids the service's host-side ViewOrder selects on the same state, with the bits of
// a full read of the device's state and nothing else written, for views with the fluid in view,
// partly in view, out of view and around the eye, for budgets from 0 past the candidates, for
// strides 1 and 3, and over the domain box or the particles' bounds (a degenerate box); its
// buffers follow new budgets, steps and a new particle count.
// ctest label `gpu`: every test skips, printing why, where no CUDA GPU can run (a build without
// CUDA, no driver, no GPU).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <string>
#include <vector>

#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "dysa/service/view_detail.h"
#include "support/gpu_test.h"
#include "support/view_subset_check.h"

namespace dysa {
namespace {

using dysa::testing::DomainOf;
using dysa::testing::ExpectViewSubsetIsViewOrders;
using dysa::testing::kGpu;
using service::StreamView;
using Vec = std::array<double, 3>;

Scene SceneOf(const std::string& solver) {
  if (solver != "seed") {
    Scene scene = dysa::testing::DamScene(solver);
    SetParam(scene.params, "particle_spacing", 0.01);  // 20 x 30 x 8 particles: many per cell
    return scene;
  }
  Scene scene = LoadScene("seed_basic");
  SetParam(scene.params, "particle_quantity", 16);
  return scene;
}

// Cameras around a domain box: the whole box in view from afar; a narrow look at a corner of it
// (part in view); a look away from it (every cell out of view); and an eye inside it.
std::vector<StreamView> ViewsOf(const Vec& lo, const Vec& hi) {
  Vec c, s;
  for (int a = 0; a < 3; ++a) c[a] = 0.5 * (lo[a] + hi[a]), s[a] = hi[a] - lo[a];
  const double far = 3 * std::max({s[0], s[1], s[2]});
  StreamView whole;
  whole.eye = {c[0], c[1], c[2] + far};
  whole.target = c;
  whole.fov_y_deg = 60;
  whole.aspect = 1.5;
  StreamView corner = whole;
  corner.target = {lo[0] + 0.2 * s[0], lo[1] + 0.3 * s[1], c[2]};
  corner.fov_y_deg = 6;
  StreamView away = whole;
  away.target = {c[0], c[1], c[2] + 2 * far};
  StreamView inside;
  inside.eye = {lo[0] + 0.1 * s[0], lo[1] + 0.2 * s[1], c[2]};
  inside.target = {hi[0], lo[1] + 0.1 * s[1], c[2]};
  inside.up = {0, 0, 1};
  inside.fov_y_deg = 90;
  inside.aspect = 0.5;
  return {whole, corner, away, inside};
}

// Budgets from none past every candidate.
std::vector<uint64_t> BudgetsOf(uint64_t candidates) {
  return {0, 1, candidates / 10, candidates / 2, candidates - 1, candidates, candidates + 7};
}

class ViewSubsetGpuTest : public ::testing::TestWithParam<std::string> {};

// After steps (storage order is no longer id order), for each view, stride and budget, the
// device's subset is ViewOrder's.
TEST_P(ViewSubsetGpuTest, TheDeviceChoosesViewOrdersSelection) {
  SKIP_WITHOUT_GPU();
  Simulation gpu(SceneOf(GetParam()), kGpu);
  for (int i = 0; i < 5; ++i) gpu.Step();
  ASSERT_EQ(gpu.alarm(), "");
  const auto [lo, hi] = DomainOf(gpu);
  const size_t n = gpu.particle_count();
  ASSERT_GT(n, 1000u);
  for (const StreamView& view : ViewsOf(lo, hi)) {
    for (uint32_t stride : {1u, 3u}) {
      const uint64_t candidates = (n + stride - 1) / stride;
      for (uint64_t budget : BudgetsOf(candidates)) {
        const std::vector<uint32_t> ids =
            ExpectViewSubsetIsViewOrders(gpu, view, lo, hi, stride, budget);
        ASSERT_EQ(ids.size(), std::min(budget, candidates));
        if (HasFailure()) return;
      }
    }
  }
}

// A degenerate box (a point, or one flat axis) spans the grid over the particles' bounds, which
// the device reduces itself.
TEST_P(ViewSubsetGpuTest, ADegenerateBoxSpansTheParticlesBounds) {
  SKIP_WITHOUT_GPU();
  Simulation gpu(SceneOf(GetParam()), kGpu);
  for (int i = 0; i < 3; ++i) gpu.Step();
  const auto [lo, hi] = DomainOf(gpu);
  const StreamView view = ViewsOf(lo, hi)[0];
  const uint64_t budget = gpu.particle_count() / 3;
  ExpectViewSubsetIsViewOrders(gpu, view, lo, lo, 1, budget);
  ExpectViewSubsetIsViewOrders(gpu, view, {0, 0, 0}, {0, 0, 0}, 2, budget / 2);
  Vec flat = hi;
  flat[1] = lo[1];
  ExpectViewSubsetIsViewOrders(gpu, view, lo, flat, 1, budget);
}

// The same request after more steps reads the new state; a smaller budget after a larger one,
// only the fields asked for, and a new particle count (a parameter change that resets) are
// served from the same buffers.
TEST_P(ViewSubsetGpuTest, TheBuffersFollowStepsBudgetsFieldsAndCount) {
  SKIP_WITHOUT_GPU();
  Simulation gpu(SceneOf(GetParam()), kGpu);
  gpu.Step();
  const auto [lo, hi] = DomainOf(gpu);
  const StreamView view = ViewsOf(lo, hi)[1];
  const uint64_t n = gpu.particle_count();
  const std::vector<uint32_t> before = ExpectViewSubsetIsViewOrders(gpu, view, lo, hi, 1, n / 4);
  for (int i = 0; i < 4; ++i) gpu.Step();
  ExpectViewSubsetIsViewOrders(gpu, view, lo, hi, 1, n / 2);
  const std::vector<uint32_t> small = ExpectViewSubsetIsViewOrders(gpu, view, lo, hi, 1, n / 8);
  // Nested: the smaller budget's ids are among the larger one's of the same state.
  const std::vector<uint32_t> large = ExpectViewSubsetIsViewOrders(gpu, view, lo, hi, 1, n / 4);
  EXPECT_TRUE(std::includes(large.begin(), large.end(), small.begin(), small.end()));
  // Only the velocities asked for: the same ids, the same values.
  std::vector<float> velocity(3 * n, testing::kNotWritten), all(3 * n, testing::kNotWritten);
  std::vector<uint32_t> ids, all_ids;
  const auto request = service::ViewRequest(view, lo, hi, 1);
  EXPECT_EQ(gpu.ReadViewSubset(request, n / 4, ids, {{}, velocity, {}}), large.size());
  EXPECT_EQ(ids, large);
  gpu.ReadViewSubset(request, n / 4, all_ids, {{}, all, {}});
  EXPECT_EQ(velocity, all);
  // A new particle count.
  if (GetParam() == "seed") {
    gpu.SetParam("particle_quantity", 12);
  } else {
    gpu.SetParam("particle_spacing", 0.02);
  }
  gpu.Step();
  ASSERT_NE(gpu.particle_count(), n);
  const uint64_t m = gpu.particle_count();
  ExpectViewSubsetIsViewOrders(gpu, view, lo, hi, 1, m / 3);
  ExpectViewSubsetIsViewOrders(gpu, view, lo, hi, 3, m);
}

std::string SolverName(const ::testing::TestParamInfo<std::string>& solver) { return solver.param; }

INSTANTIATE_TEST_SUITE_P(Solvers, ViewSubsetGpuTest, ::testing::Values("seed", "wcsph", "dfsph"),
                         SolverName);

}  // namespace
}  // namespace dysa
