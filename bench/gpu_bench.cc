// The solvers on a CUDA GPU against the same machine's CPU cores, from the thesis scene
// (91,125 particles) to the largest block that fits: ms per pass, particle-steps/s, pair
// interactions within the kernel support per second, simulated seconds per wall second, GPU
// bytes per particle, speed-up.
//
//   build/release/bench/gpu_bench [--solvers seed,wcsph,dfsph] [--device cuda:0]
//       [--sizes 91125,1000000,10000000,100000000] [--physical-sizes 91125,1000000]
//       [--cpu-max 10000000] [--threads N] [--set NAME=VALUE ...] [--out bench/results]
//
// --set overrides a parameter of every scene (repeatable), e.g. --set warm_start=0.5 for dfsph.
// seed: every size is a cube of the thesis fluid (seed_test_scene: its smoothing radius 0.3 m
// and its particle spacing 5 / 44 m, so the same density and neighbours per particle) in a box
// --domain-ratio times its edge. wcsph, dfsph: a 3D dam break, a water column 0.5 x 1 x 0.5 m
// against the wall of a 2 x 1.25 x 0.5 m tank with a no-slip floor, at the particle spacing that
// gives the size, measured from t = --warmup-time (0.02 s: the column falling) for --seconds of
// wall time. The
// CPU starts from the GPU's state at the start of its timed steps.
// Writes gpu_<solver>_<gpu>.csv (one row per size and device) and gpu_<solver>_passes_<gpu>.csv
// (per pass). The CPU runs in the same process, on --threads threads (default: all cores), for
// sizes up to --cpu-max.
#include <omp.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include "dysa/core/device.h"
#include "dysa/core/neighbor_grid.h"
#include "dysa/core/simulation.h"
#include "dysa/core/solver.h"

namespace {

using Clock = std::chrono::steady_clock;

// The thesis scene's fluid as a cube of q^3 particles (q = 45 is the thesis scene itself).
dysa::Scene ThesisBlock(int q, double domain_ratio) {
  dysa::Scene scene = dysa::LoadScene("seed_test_scene");
  const double spacing = 5.0 / 44.0;  // the thesis's: spawn_size / (particle_quantity - 1)
  const double edge = spacing * (q - 1);
  scene.fluid_blocks[0].size = dysa::Vec3d::Constant(edge);
  scene.fluid_blocks[0].particles_per_axis = Eigen::Vector3i::Constant(q);
  const double half = std::max(5.0, 0.5 * domain_ratio * edge);
  scene.domain.min = dysa::Vec3d::Constant(-half);
  scene.domain.max = dysa::Vec3d::Constant(half);
  scene.name = "thesis_block_" + std::to_string(q);
  return scene;
}

// The dam break of the physical solvers with about n particles.
dysa::Scene DamBreak(const std::string& solver, double n) {
  dysa::Scene scene = dysa::ParseScene(R"({
    "domain": {"min": [0, 0, 0], "max": [2, 1.25, 0.5], "no_slip": [false, true, false]},
    "fluid_blocks": [{"center": [0.25, 0.5, 0.25], "size": [0.5, 1, 0.5]}],
    "params": {"gravity": -9.81, "speed_of_sound": 60, "kinematic_viscosity": 1e-6,
               "max_time_step": 0.002}
  })");
  scene.solver = solver;
  // 0.25 m^3 of water: n d^3 = 0.25.
  dysa::SetParam(scene.params, "particle_spacing", std::cbrt(0.25 / n));
  scene.name = "dam_break_" + solver;
  return scene;
}

// Mean number of other particles within the kernel's support, over a sample of particles
// (the pairs each neighbour pass evaluates per particle). Around the positions: the seed's passes
// search around positions predicted 1/120 s ahead, nearly the same count.
double MeanNeighbours(const dysa::Simulation& sim) {
  const dysa::ParticleArrays& p = sim.state().particles;
  const dysa::Real h = dysa::Real(sim.model().kernel_support);
  dysa::NeighborGrid grid;
  grid.Configure(sim.model().domain, h, sim.model().periodic);
  grid.Sort(p.position);
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
  double simulated_per_wall = 0;  // simulated seconds per wall second
  double neighbours = 0;
  // dfsph: the solves' iterations per step (each is two sweeps over the pairs and a sum the host
  // waits for), what its density_solve time is made of.
  double density_iterations = 0;
  double divergence_iterations = 0;
  uint64_t device_bytes = 0;
  std::vector<dysa::PassProfile> passes;
  double particle_steps_per_s() const { return double(particles) / (ms_per_step * 1e-3); }
  double pairs_per_s() const { return particle_steps_per_s() * neighbours; }
};

// Steps `scene` on `device`: `warmup` steps and up to `warmup_time` simulated seconds untimed
// (or none, from `start` when given), then as many timed steps as fit in `budget_s`. `start`, if
// not null and empty, receives the state the timed steps started from.
Row Measure(const dysa::Scene& scene, const dysa::Device& device, int warmup, double budget_s,
            int max_steps, double warmup_time, std::optional<dysa::Checkpoint>* start_state) {
  Row row;
  const auto setup = Clock::now();
  dysa::Simulation sim(scene, device);
  row.setup_s = std::chrono::duration<double>(Clock::now() - setup).count();
  row.device = sim.DeviceDescription();
  row.particles = sim.particle_count();
  if (start_state && start_state->has_value()) {
    sim.RestoreCheckpoint(**start_state);
  } else {
    for (int i = 0; i < warmup || sim.time() < warmup_time; ++i) sim.Step();
    if (start_state) *start_state = sim.SaveCheckpoint();
  }
  sim.ResetProfile();
  const double start_time = sim.time();
  const auto start = Clock::now();
  double elapsed = 0;
  while (row.steps < max_steps && (row.steps < 3 || elapsed < budget_s)) {
    sim.Step();
    ++row.steps;
    row.density_iterations += sim.solver_stats().density_iterations;
    row.divergence_iterations += sim.solver_stats().divergence_iterations;
    elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  }
  row.ms_per_step = 1e3 * elapsed / row.steps;
  row.density_iterations /= row.steps;
  row.divergence_iterations /= row.steps;
  row.simulated_per_wall = (sim.time() - start_time) / elapsed;
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
  std::vector<std::string> solvers = {"seed", "wcsph", "dfsph"};
  std::vector<long long> sizes = {91125, 1000000, 10000000, 100000000};
  std::vector<long long> physical_sizes = {91125, 1000000, 10000000};
  long long cpu_max = 10000000;
  int threads = omp_get_num_procs();
  int warmup = 20;
  double physical_warmup = 0.02;
  double budget_s = 3.0;
  int max_steps = 500;
  double domain_ratio = 1.4;
  std::string out_dir = "bench/results";
  app.add_option("--device", device_text, "The GPU: cuda or cuda:N")->capture_default_str();
  app.add_option("--sizes", sizes, "Particle counts (rounded to cubes), comma separated")
      ->delimiter(',')
      ->check(CLI::Range(8LL, 2000000000LL));
  app.add_option("--solvers", solvers, "Solvers, comma separated")->delimiter(',');
  app.add_option("--physical-sizes", physical_sizes, "Particle counts of wcsph and dfsph")
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
  app.add_option("--warmup-time", physical_warmup,
                 "Untimed simulated seconds of wcsph and dfsph (the column falling), s")
      ->check(CLI::Range(0.0, 10.0))
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
  std::vector<std::string> sets;
  app.add_option("--set", sets, "Override a parameter of every scene, NAME=VALUE (repeatable)");
  CLI11_PARSE(app, argc, argv);

  try {
    const dysa::Device gpu = dysa::ParseDevice(device_text);
    if (!gpu.is_cuda()) throw dysa::ConfigError("device", "gpu_bench needs a CUDA device");
    const dysa::DeviceInfo info = dysa::QueryDevice(gpu);  // throws, naming what is missing
    omp_set_num_threads(threads);
    std::printf("GPU: %s; CPU: %d threads\n", info.Describe(gpu).c_str(), threads);
    std::filesystem::create_directories(out_dir);
    const std::string tag = FileSafe(info.name);
    for (const std::string& solver : solvers) {
      dysa::FindSolver(solver);  // throws, naming the known solvers
      const bool physical = solver != "seed";
      const std::string base = out_dir + "/gpu_" + solver;
      std::ofstream summary(base + "_" + tag + ".csv");
      std::ofstream passes(base + "_passes_" + tag + ".csv");
      summary << "device,particles,steps,ms_per_step,particle_steps_per_s,neighbours,"
                 "pairs_per_s,simulated_s_per_wall_s,device_bytes_per_particle,speedup_over_cpu,"
                 "setup_s,density_iterations_per_step,divergence_iterations_per_step\n";
      passes << "device,particles,pass,ms\n";
      for (long long size : physical ? physical_sizes : sizes) {
        const int q = std::max(2, int(std::lround(std::cbrt(double(size)))));
        dysa::Scene scene =
            physical ? DamBreak(solver, double(size)) : ThesisBlock(q, domain_ratio);
        // Throws ConfigError naming the parameter and its range, reported below.
        for (const std::string& assignment : sets)
          dysa::SetParamFromString(scene.params, assignment);
        const double warmup_time = physical ? physical_warmup : 0.0;
        // The CPU starts from the state the GPU's timed steps started from.
        std::optional<dysa::Checkpoint> start;
        std::vector<Row> rows;
        rows.push_back(Measure(scene, gpu, warmup, budget_s, max_steps, warmup_time,
                               size <= cpu_max ? &start : nullptr));
        if (size <= cpu_max) {
          rows.push_back(Measure(scene, dysa::Device{}, 0, budget_s, max_steps, 0, &start));
        }
        const double gpu_ms = rows.front().ms_per_step;
        for (const Row& r : rows) {
          const bool on_gpu = &r == &rows.front();
          const double speedup = rows.size() > 1 ? rows.back().ms_per_step / gpu_ms : 0.0;
          std::printf(
              "%-6s %-38s %11zu particles: %9.3f ms/step, %.3g particle-steps/s, %.1f "
              "neighbours, %.3g pairs/s, %.3g simulated s per wall s",
              solver.c_str(), r.device.c_str(), r.particles, r.ms_per_step,
              r.particle_steps_per_s(), r.neighbours, r.pairs_per_s(), r.simulated_per_wall);
          if (on_gpu) {
            std::printf(", %.1f GPU bytes/particle", double(r.device_bytes) / double(r.particles));
            if (speedup > 0) std::printf(", %.1fx the CPU", speedup);
          }
          std::printf(" (%d steps, set-up %.1f s)\n", r.steps, r.setup_s);
          if (r.density_iterations + r.divergence_iterations > 0) {
            std::printf("    iterations per step: %.2f density, %.2f divergence\n",
                        r.density_iterations, r.divergence_iterations);
          }
          summary << '"' << r.device << "\"," << r.particles << ',' << r.steps << ','
                  << r.ms_per_step << ',' << r.particle_steps_per_s() << ',' << r.neighbours << ','
                  << r.pairs_per_s() << ',' << r.simulated_per_wall << ','
                  << (on_gpu ? double(r.device_bytes) / double(r.particles) : 0.0) << ','
                  << (on_gpu ? speedup : 0.0) << ',' << r.setup_s << ',' << r.density_iterations
                  << ',' << r.divergence_iterations << '\n';
          for (const dysa::PassProfile& p : r.passes) {
            const double ms = p.calls ? p.total_ms / double(p.calls) : 0.0;
            std::printf("    %-18s %9.3f ms\n", p.name.c_str(), ms);
            passes << '"' << r.device << "\"," << r.particles << ',' << p.name << ',' << ms << '\n';
          }
        }
        summary.flush();
        passes.flush();
      }
      std::printf("wrote %s_%s.csv and %s_passes_%s.csv\n", base.c_str(), tag.c_str(), base.c_str(),
                  tag.c_str());
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "gpu_bench: %s\n", e.what());
    return 2;
  }
  return 0;
}
