// A view stream's subset chosen where the particles live (docs/server.md, "View-dependent
// detail", "On a GPU"): per particle count and budget, on one device, the milliseconds of a
// solver step, of a full read of the positions in id order (what a view stream's frame gathers
// today), of the host's ViewOrder on that read, and of Simulation::ReadViewSubset (on a GPU:
// chosen and packed on the device, only the chosen particles cross), and the bytes each read
// moves to the host. Checks that both choose the same ids. Prints a table and writes
// bench/results/view_subset_<device>.csv.
//
//   build/release/bench/view_subset_bench [--device cuda:0] [--particles 1000000 10000000
//       100000000] [--budgets 2000000] [--solver wcsph] [--out bench/results]
#include <CLI/CLI.hpp>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "dysa/core/device.h"
#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "dysa/service/view_detail.h"

namespace {

using Clock = std::chrono::steady_clock;

// gpu_bench's dam break: a water column of about n particles in a 2 x 1.25 x 0.5 m tank.
dysa::Scene DamBreak(const std::string& solver, double n) {
  dysa::Scene scene = dysa::ParseScene(R"({
    "domain": {"min": [0, 0, 0], "max": [2, 1.25, 0.5], "no_slip": [false, true, false]},
    "fluid_blocks": [{"center": [0.25, 0.5, 0.25], "size": [0.5, 1, 0.5]}],
    "params": {"gravity": -9.81, "speed_of_sound": 60, "kinematic_viscosity": 1e-6,
               "max_time_step": 0.002}
  })");
  scene.solver = solver;
  dysa::SetParam(scene.params, "particle_spacing", std::cbrt(0.25 / n));
  return scene;
}

// The median of `reps` timings of f, ms.
template <class F>
double MedianMs(int reps, F&& f) {
  std::vector<double> t;
  for (int r = 0; r < reps; ++r) {
    const auto start = Clock::now();
    f();
    t.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

int Run(const std::string& device_text, const std::string& solver, const std::string& out_dir,
        const std::vector<double>& sizes, const std::vector<uint64_t>& budgets, int reps) {
  const dysa::Device device = dysa::ParseDevice(device_text);
  std::filesystem::create_directories(out_dir);
  std::string tag = device_text;
  std::replace(tag.begin(), tag.end(), ':', '_');
  std::ofstream csv(out_dir + "/view_subset_" + tag + ".csv");
  csv << "device,solver,particles,chosen,step_ms,full_read_ms,full_read_bytes,view_order_ms,"
         "read_view_subset_ms,read_view_subset_bytes,same_ids\n";
  std::printf("%-8s %11s %9s %9s %11s %10s %12s %9s %10s %5s\n", "device", "particles", "chosen",
              "step ms", "full rd ms", "full MB", "ViewOrder ms", "subset ms", "subset MB", "same");
  for (double size : sizes) {
    dysa::Simulation sim(DamBreak(solver, size), device);
    for (int i = 0; i < 3; ++i) sim.Step();
    const size_t n = sim.particle_count();
    const dysa::Aabb& d = sim.model().domain;
    const std::array<double, 3> lo = {d.min[0], d.min[1], d.min[2]};
    const std::array<double, 3> hi = {d.max[0], d.max[1], d.max[2]};
    dysa::service::StreamView view;  // from the front, a little above: most of the tank in view
    view.eye = {1, 1.5, 3};
    view.target = {0.6, 0.4, 0.25};
    view.fov_y_deg = 40;
    view.aspect = 16.0 / 9;
    const double step_ms = MedianMs(reps, [&] { sim.Step(); });
    std::vector<float> all(3 * n), chosen(3 * n);
    const double full_ms = MedianMs(reps, [&] { sim.ReadParticlesById({all, {}, {}}); });
    for (uint64_t budget : budgets) {
      std::vector<uint32_t> host_ids, device_ids;
      const double order_ms = MedianMs(
          reps, [&] { host_ids = dysa::service::ViewOrder(view, all, lo, hi, 1).Select(budget); });
      const auto request = dysa::service::ViewRequest(view, lo, hi, 1);
      sim.ReadViewSubset(request, budget, device_ids, {chosen, {}, {}});  // allocations
      const double subset_ms = MedianMs(reps, [&] {
        sim.ReadViewSubset(request, budget, device_ids, {chosen, {}, {}});
      });
      const bool same = host_ids == device_ids;
      const double full_mb = 12.0 * double(n) / 1e6;
      // Ids and positions of the chosen, and the grid's counts (down) and weights (up).
      const double subset_mb =
          device.is_cuda() ? (16.0 * double(device_ids.size()) + 12.0 * 32768) / 1e6 : full_mb;
      std::printf("%-8s %11zu %9zu %9.2f %11.2f %10.1f %12.2f %9.2f %10.1f %5s\n",
                  device_text.c_str(), n, device_ids.size(), step_ms, full_ms, full_mb, order_ms,
                  subset_ms, subset_mb, same ? "yes" : "NO");
      csv << device_text << ',' << solver << ',' << n << ',' << device_ids.size() << ',' << step_ms
          << ',' << full_ms << ',' << 12 * n << ',' << order_ms << ',' << subset_ms << ','
          << uint64_t(subset_mb * 1e6) << ',' << (same ? 1 : 0) << '\n';
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"A view's subset chosen on the device against a full read and ViewOrder"};
  std::string device_text = "cuda:0", solver = "wcsph", out_dir = "bench/results";
  std::vector<double> sizes = {1e6, 1e7};
  std::vector<uint64_t> budgets = {2000000};
  int reps = 5;
  app.add_option("--device", device_text, "cpu, cuda or cuda:N")->capture_default_str();
  app.add_option("--particles", sizes, "Particle counts (about)");
  app.add_option("--budgets", budgets, "Particles chosen per view");
  app.add_option("--solver", solver, "wcsph or dfsph")->capture_default_str();
  app.add_option("--reps", reps, "Timings per figure (the median)")->capture_default_str();
  app.add_option("--out", out_dir, "CSV directory")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  try {
    return Run(device_text, solver, out_dir, sizes, budgets, reps);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "view_subset_bench: %s\n", e.what());
    return 1;
  }
}
