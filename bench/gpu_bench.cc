// The seed solver on a CUDA GPU against the same machine's CPU cores, from the thesis scene
// (91,125 particles) to the largest block that fits: ms per pass, particle-steps/s, pair
// interactions within the kernel support per second, GPU bytes per particle, speed-up.
//
//   build/release/bench/gpu_bench [--device cuda:0] [--sizes 91125,1000000,10000000,100000000]
//                                 [--cpu-max 10000000] [--threads N] [--out bench/results]
//
// Every size is a cube of the thesis fluid (seed_test_scene: its smoothing radius 0.3 m and its
// particle spacing 5 / 44 m, so the same density and neighbours per particle) in a box
// --domain-ratio times its edge. Writes gpu_seed_<gpu>.csv (one row per size and device) and
// gpu_seed_passes_<gpu>.csv (per pass). The CPU runs in the same process, on --threads threads
// (default: all cores), for sizes up to --cpu-max.
#include <omp.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "dysa/core/device.h"
#include "dysa/core/neighbor_grid.h"
#include "dysa/core/simulation.h"

namespace {

using Clock = std::chrono::steady_clock;

// The thesis scene's fluid as a cube of q^3 particles (q = 45 is the thesis scene itself).
dysa::Scene ThesisBlock(int q, double domain_ratio) {
  dysa::Scene scene = dysa::LoadScene("seed_test_scene");
  const double spacing = 5.0 / 44.0;  // the thesis's: spawn_size / (particle_quantity - 1)
  const double edge = spacing * (q - 1);
  dysa::SetParam(scene.params, "particle_quantity", q);
  scene.fluid_blocks[0].size = dysa::Vec3d::Constant(edge);
  scene.fluid_blocks[0].particles_per_axis = Eigen::Vector3i::Constant(q);
  const double half = std::max(5.0, 0.5 * domain_ratio * edge);
  scene.domain.min = dysa::Vec3d::Constant(-half);
  scene.domain.max = dysa::Vec3d::Constant(half);
  scene.name = "thesis_block_" + std::to_string(q);
  return scene;
}

// Mean number of other particles within the smoothing radius, over a sample of particles
// (the pairs each neighbour pass evaluates per particle).
double MeanNeighbours(const dysa::Simulation& sim) {
  const dysa::ParticleArrays& p = sim.state().particles;
  const dysa::Real h = dysa::Real(sim.params().smoothing_radius);
  dysa::NeighborGrid grid;
  grid.Configure(sim.model().domain, h, sim.model().periodic);
  grid.Sort(p.predicted);
  const int64_t n = int64_t(p.size());
  const int64_t stride = std::max<int64_t>(1, n / 20000);
  int64_t pairs = 0, sampled = 0;
#pragma omp parallel for reduction(+ : pairs, sampled) schedule(static)
  for (int64_t k = 0; k < n; k += stride) {
    const dysa::Vec3 x(grid.xs()[k], grid.ys()[k], grid.zs()[k]);
    grid.ForEachNeighborRun(
        grid.SortedCell(uint32_t(k)), [&](uint32_t begin, uint32_t end, const dysa::Vec3& shift) {
          for (uint32_t j = begin; j < end; ++j) {
            const dysa::Vec3 d(grid.xs()[j] - x.x() - shift.x(), grid.ys()[j] - x.y() - shift.y(),
                               grid.zs()[j] - x.z() - shift.z());
            if (j != k && d.squaredNorm() < h * h) ++pairs;
          }
        });
    ++sampled;
  }
  return sampled ? double(pairs) / double(sampled) : 0.0;
}

struct Row {
  std::string device;
  size_t particles = 0;
  int steps = 0;
  double setup_s = 0;
  double ms_per_step = 0;
  double neighbours = 0;
  uint64_t device_bytes = 0;
  std::vector<dysa::PassProfile> passes;
  double particle_steps_per_s() const { return double(particles) / (ms_per_step * 1e-3); }
  double pairs_per_s() const { return particle_steps_per_s() * neighbours; }
};

Row Measure(const dysa::Scene& scene, const dysa::Device& device, int warmup, double budget_s,
            int max_steps) {
  Row row;
  const auto setup = Clock::now();
  dysa::Simulation sim(scene, device);
  row.setup_s = std::chrono::duration<double>(Clock::now() - setup).count();
  row.device = sim.DeviceDescription();
  row.particles = sim.particle_count();
  for (int i = 0; i < warmup; ++i) sim.Step();
  sim.ResetProfile();
  const auto start = Clock::now();
  double elapsed = 0;
  while (row.steps < max_steps && (row.steps < 3 || elapsed < budget_s)) {
    sim.Step();
    ++row.steps;
    elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  }
  row.ms_per_step = 1e3 * elapsed / row.steps;
  row.passes.assign(sim.profile().begin(), sim.profile().end());
  row.device_bytes = sim.DeviceBytes();
  row.neighbours = MeanNeighbours(sim);
  if (!sim.alarm().empty()) std::printf("  alarm: %s\n", sim.alarm().c_str());
  return row;
}

std::string FileSafe(std::string text) {
  for (char& c : text) {
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  }
  return text;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"The seed solver on a CUDA GPU against the CPU cores"};
  std::string device_text = "cuda:0";
  std::vector<long long> sizes = {91125, 1000000, 10000000, 100000000};
  long long cpu_max = 10000000;
  int threads = omp_get_num_procs();
  int warmup = 20;
  double budget_s = 3.0;
  int max_steps = 500;
  double domain_ratio = 1.4;
  std::string out_dir = "bench/results";
  app.add_option("--device", device_text, "The GPU: cuda or cuda:N")->capture_default_str();
  app.add_option("--sizes", sizes, "Particle counts (rounded to cubes), comma separated")
      ->delimiter(',')
      ->check(CLI::Range(8LL, 2000000000LL));
  app.add_option("--cpu-max", cpu_max, "Largest count also run on the CPU (0: none)")
      ->capture_default_str();
  app.add_option("--threads", threads, "CPU threads")
      ->check(CLI::Range(1, 4096))
      ->capture_default_str();
  app.add_option("--warmup", warmup, "Untimed steps first")
      ->check(CLI::Range(0, 10000))
      ->capture_default_str();
  app.add_option("--seconds", budget_s, "Timed seconds per run (at least 3 steps)")
      ->check(CLI::Range(0.0, 600.0))
      ->capture_default_str();
  app.add_option("--max-steps", max_steps, "Most timed steps per run")
      ->check(CLI::Range(3, 100000))
      ->capture_default_str();
  app.add_option("--domain-ratio", domain_ratio, "Domain edge over the block's edge")
      ->check(CLI::Range(1.0, 10.0))
      ->capture_default_str();
  app.add_option("--out", out_dir, "Directory for the CSV files")->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  try {
    const dysa::Device gpu = dysa::ParseDevice(device_text);
    if (!gpu.is_cuda()) throw dysa::ConfigError("device", "gpu_bench needs a CUDA device");
    const dysa::DeviceInfo info = dysa::QueryDevice(gpu);  // throws, naming what is missing
    omp_set_num_threads(threads);
    std::printf("GPU: %s; CPU: %d threads\n", info.Describe(gpu).c_str(), threads);
    std::filesystem::create_directories(out_dir);
    const std::string tag = FileSafe(info.name);
    std::ofstream summary(out_dir + "/gpu_seed_" + tag + ".csv");
    std::ofstream passes(out_dir + "/gpu_seed_passes_" + tag + ".csv");
    summary << "device,particles,steps,ms_per_step,particle_steps_per_s,neighbours,"
               "pairs_per_s,device_bytes_per_particle,speedup_over_cpu,setup_s\n";
    passes << "device,particles,pass,ms\n";
    for (long long size : sizes) {
      const int q = std::max(2, int(std::lround(std::cbrt(double(size)))));
      const dysa::Scene scene = ThesisBlock(q, domain_ratio);
      std::vector<Row> rows;
      rows.push_back(Measure(scene, gpu, warmup, budget_s, max_steps));
      if (size <= cpu_max)
        rows.push_back(Measure(scene, dysa::Device{}, std::min(warmup, 5), budget_s, max_steps));
      const double gpu_ms = rows.front().ms_per_step;
      for (const Row& r : rows) {
        const bool on_gpu = &r == &rows.front();
        const double speedup = rows.size() > 1 ? rows.back().ms_per_step / gpu_ms : 0.0;
        std::printf(
            "%-40s %11zu particles: %9.3f ms/step, %.3g particle-steps/s, %.1f neighbours, "
            "%.3g pairs/s",
            r.device.c_str(), r.particles, r.ms_per_step, r.particle_steps_per_s(), r.neighbours,
            r.pairs_per_s());
        if (on_gpu) {
          std::printf(", %.1f GPU bytes/particle", double(r.device_bytes) / double(r.particles));
          if (speedup > 0) std::printf(", %.1fx the CPU", speedup);
        }
        std::printf(" (%d steps, set-up %.1f s)\n", r.steps, r.setup_s);
        summary << '"' << r.device << "\"," << r.particles << ',' << r.steps << ',' << r.ms_per_step
                << ',' << r.particle_steps_per_s() << ',' << r.neighbours << ',' << r.pairs_per_s()
                << ',' << (on_gpu ? double(r.device_bytes) / double(r.particles) : 0.0) << ','
                << (on_gpu ? speedup : 0.0) << ',' << r.setup_s << '\n';
        for (const dysa::PassProfile& p : r.passes) {
          const double ms = p.calls ? p.total_ms / double(p.calls) : 0.0;
          std::printf("    %-16s %9.3f ms\n", p.name.c_str(), ms);
          passes << '"' << r.device << "\"," << r.particles << ',' << p.name << ',' << ms << '\n';
        }
      }
      summary.flush();
      passes.flush();
    }
    std::printf("wrote %s/gpu_seed_%s.csv and gpu_seed_passes_%s.csv\n", out_dir.c_str(),
                tag.c_str(), tag.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "gpu_bench: %s\n", e.what());
    return 2;
  }
  return 0;
}
