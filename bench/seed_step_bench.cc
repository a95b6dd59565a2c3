// Throughput of the seed solver on the thesis's 91,125-particle scene, per pass, for several
// thread counts. Writes bench/results/seed_step.csv (per pass) and seed_step_summary.csv.
//
//   build/release/bench/seed_step_bench [--scene NAME] [--warmup N] [--steps N]
//                                       [--threads 1,2] [--device cpu|cuda[:N]]
//                                       [--out bench/results]
//
// On a GPU (--device cuda) the thread count is the host's alone; one is enough.
#include <omp.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "dysa/core/device.h"
#include "dysa/core/simulation.h"
#include "dysa/core/types.h"

namespace {

struct Result {
  int threads = 0;
  size_t particles = 0;
  uint64_t steps = 0;
  double wall_s = 0;
  uint64_t hash = 0;
  std::vector<dysa::PassProfile> passes;
  std::string device;  // Simulation::DeviceDescription()
  double ms_per_step() const { return 1e3 * wall_s / double(steps); }
  double mps() const { return double(particles) * double(steps) / wall_s / 1e6; }
};

Result Measure(const dysa::Scene& scene, const dysa::Device& device, int threads, int warmup,
               int steps) {
  omp_set_num_threads(threads);
  dysa::Simulation sim(scene, device);
  for (int i = 0; i < warmup; ++i) sim.Step();
  sim.ResetProfile();
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < steps; ++i) sim.Step();
  Result r;
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  r.threads = threads;
  r.particles = sim.particle_count();
  r.steps = uint64_t(steps);
  r.hash = dysa::StateHash(sim.state());
  r.passes.assign(sim.profile().begin(), sim.profile().end());
  r.device = sim.DeviceDescription();
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Seed solver throughput per pass and thread count"};
  std::string scene_name = "seed_test_scene";
  int warmup = 60;
  int steps = 200;
  std::vector<int> thread_counts = {1, 2};
  std::string out_dir = "bench/results";
  app.add_option("--scene", scene_name, "Built-in scene or JSON file")->capture_default_str();
  app.add_option("--warmup", warmup, "Steps before timing (the spawn cube starts to fall)")
      ->check(CLI::Range(0, 100000))
      ->capture_default_str();
  app.add_option("--steps", steps, "Timed steps")
      ->check(CLI::Range(1, 1000000))
      ->capture_default_str();
  app.add_option("--threads", thread_counts, "Thread counts, comma separated")
      ->delimiter(',')
      ->check(CLI::Range(1, 1024));
  std::string device_text = "cpu";
  app.add_option("--device", device_text, "Where the steps run: cpu, cuda or cuda:N")
      ->capture_default_str();
  app.add_option("--out", out_dir, "Directory for the CSV files")->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  dysa::Device device;
  try {
    device = dysa::ParseDevice(device_text);
    dysa::QueryDevice(device);  // no GPU: say what is missing before loading anything
  } catch (const dysa::ConfigError& e) {
    std::fprintf(stderr, "seed_step_bench: error: --device %s: %s\n", device_text.c_str(),
                 e.message().c_str());
    return 2;
  }
  try {
    const dysa::Scene scene = dysa::LoadScene(scene_name);
    std::vector<Result> results;
    for (int t : thread_counts) {
      results.push_back(Measure(scene, device, t, warmup, steps));
      const Result& r = results.back();
      std::printf(
          "%s: %zu particles, %d threads on %s: %.2f ms/step, %.2f million particle-steps/s, "
          "state hash %016llx\n",
          scene_name.c_str(), r.particles, t, r.device.c_str(), r.ms_per_step(), r.mps(),
          static_cast<unsigned long long>(r.hash));
      for (const dysa::PassProfile& p : r.passes) {
        std::printf("    %-16s %8.3f ms/step  %5.1f%%\n", p.name.c_str(),
                    p.total_ms / double(r.steps), 100 * 1e-3 * p.total_ms / r.wall_s);
      }
    }
    std::filesystem::create_directories(out_dir);
    std::ofstream summary(std::filesystem::path(out_dir) / "seed_step_summary.csv");
    summary << "scene,threads,particles,steps,wall_s,ms_per_step,million_particle_steps_per_s,"
               "speedup_vs_first\n";
    std::ofstream passes(std::filesystem::path(out_dir) / "seed_step.csv");
    passes << "scene,threads,pass,ms_per_step,share_percent\n";
    for (const Result& r : results) {
      summary << scene_name << ',' << r.threads << ',' << r.particles << ',' << r.steps << ','
              << r.wall_s << ',' << r.ms_per_step() << ',' << r.mps() << ','
              << results.front().wall_s / r.wall_s << '\n';
      for (const dysa::PassProfile& p : r.passes) {
        passes << scene_name << ',' << r.threads << ',' << p.name << ','
               << p.total_ms / double(r.steps) << ',' << 100 * 1e-3 * p.total_ms / r.wall_s << '\n';
      }
    }
    bool same = true;
    for (const Result& r : results) same &= r.hash == results.front().hash;
    std::printf("state hashes %s across thread counts\n", same ? "identical" : "DIFFER");
    std::printf("wrote %s/seed_step.csv and seed_step_summary.csv\n", out_dir.c_str());
    return same ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "seed_step_bench: error: %s\n", e.what());
    return 1;
  }
}
