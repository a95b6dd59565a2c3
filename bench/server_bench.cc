// Server benchmark: frames delivered to 1, 4 and 16 subscribers, the simulation's slowdown with
// subscribers against none, the pipeline's capacity (encode, gRPC on loopback, decode) for the
// thesis scene and a 1M-particle block, memory with a stalled subscriber over time, and the
// live server with its simulation on a CUDA GPU for blocks of 1M and 10M particles, and the
// slowdown of a GPU run that a budgeted stream watches. One file per part in server_bench/.
//
// Everything runs in this process: the real Server and SimulationHost on a loopback port, and
// clients that each have their own connection and decode every frame, as a viewer does.
//
//   server_bench                       # all parts, results in bench/results/server_*.csv
//   server_bench --part pipeline --large 100 --seconds 5
//   server_bench --part slowdown --slowdown-subscribers 4 --pairs 20 --window 3
//   server_bench --part live --device cuda  # the simulations step on the GPU
//   server_bench --part gpu --gpu-sizes 1000000,10000000   # on cuda:0 unless --device says
//   server_bench --part gpu_watch --gpu-sizes 1000000,10000000 --watch-percent 1 --watch-rounds 3
//                --seconds 5   # the step rate with and without a budgeted stream, on cuda:0
#include "server_bench/server_bench.h"

#include <omp.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "dysa/core/device.h"
#include "dysa/core/scene.h"

using server_bench::Gpu;
using server_bench::GpuWatch;
using server_bench::LargeBlock;
using server_bench::Live;
using server_bench::Mode;
using server_bench::ParseCounts;
using server_bench::Pipeline;
using server_bench::Slowdown;
using server_bench::Stalled;

int main(int argc, char** argv) {
  CLI::App app{"server_bench: frame delivery, fan-out and memory of dysa-server"};
  std::string part = "all";
  double seconds = 5;
  double stalled_seconds = 60;
  int large = 100;
  std::string counts_text = "1,4,16";
  std::string out_dir = "bench/results";
  int solver_threads = 0;
  int slowdown_subscribers = 4;
  int pairs = 12;
  double window_seconds = 3;
  app.add_option("--part", part,
                 "live, slowdown, pipeline, stalled, gpu, gpu_watch or all (gpu: with a CUDA "
                 "--device, or alone, where it defaults to cuda:0, as gpu_watch does; all does "
                 "not run gpu_watch)")
      ->check(CLI::IsMember({"live", "slowdown", "pipeline", "stalled", "gpu", "gpu_watch", "all"}))
      ->capture_default_str();
  app.add_option("--seconds", seconds, "Measurement per configuration")->capture_default_str();
  app.add_option("--stalled-seconds", stalled_seconds, "Length of the stalled-subscriber run")
      ->capture_default_str();
  app.add_option("--large", large, "Particles per axis of the large block")->capture_default_str();
  app.add_option("--subscribers", counts_text, "Subscriber counts")->capture_default_str();
  app.add_option("--out", out_dir, "Output directory")->capture_default_str();
  app.add_option("--solver-threads", solver_threads,
                 "OpenMP threads of the live part's solver (0: all cores; the publishing thread "
                 "gets the cores left, at least one)")
      ->check(CLI::Range(0, 1024))
      ->capture_default_str();
  app.add_option("--slowdown-subscribers", slowdown_subscribers,
                 "Subscribers of the slowdown part's subscribed windows")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  app.add_option("--pairs", pairs, "Subscribed windows of the slowdown part")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  app.add_option("--window", window_seconds, "Length of each slowdown window, s")
      ->check(CLI::Range(0.5, 60.0))
      ->capture_default_str();
  std::string device_text = "cpu";
  app.add_option("--device", device_text,
                 "Where every part's simulation steps: cpu, cuda or cuda:N (frames are gathered, "
                 "encoded and sent on the CPU either way); --part gpu alone: cuda:0")
      ->capture_default_str();
  std::string gpu_sizes_text = "1000000,10000000";
  app.add_option("--gpu-sizes", gpu_sizes_text,
                 "Particles of the gpu part's blocks, at least (the smallest cube of particles "
                 "with as many)")
      ->capture_default_str();
  std::string gpu_counts_text = "0,1";
  app.add_option("--gpu-subscribers", gpu_counts_text,
                 "Subscriber counts of the gpu part (each decodes every frame)")
      ->capture_default_str();
  int gpu_warmup = 10;
  app.add_option("--gpu-warmup", gpu_warmup, "Frames the gpu part steps before each window")
      ->check(CLI::Range(1, 10000))
      ->capture_default_str();
  double watch_percent = 1;
  app.add_option("--watch-percent", watch_percent,
                 "The gpu_watch part's budget: particles a frame, % of the block's")
      ->check(CLI::Range(0.0001, 100.0))
      ->capture_default_str();
  int watch_rounds = 3;
  app.add_option("--watch-rounds", watch_rounds,
                 "Watched windows of the gpu_watch part (each between two unwatched ones)")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  // The gpu parts step on the GPU unless --device names a device (cpu: a dry run of the part).
  if ((part == "gpu" || part == "gpu_watch") && app.count("--device") == 0) device_text = "cuda";

  dysa::Device device;
  try {
    device = dysa::ParseDevice(device_text);
    std::printf("device %s\n", dysa::QueryDevice(device).Describe(device).c_str());
  } catch (const dysa::ConfigError& e) {
    std::fprintf(stderr, "server_bench: error: --device %s: %s\n", device_text.c_str(),
                 e.message().c_str());
    return 2;
  }

  std::filesystem::create_directories(out_dir);
  std::printf("%d OpenMP threads\n", omp_get_max_threads());
  const std::vector<int> counts = ParseCounts(counts_text);
  if (part == "live" || part == "pipeline" || part == "all") {
    std::ofstream csv(std::filesystem::path(out_dir) / "server_fanout.csv",
                      part == "pipeline" ? std::ios::app : std::ios::trunc);
    if (part != "pipeline") {
      csv << "part,scene,particles,subscribers,simulated_or_encoded_fps,delivered_fps_mean,"
             "delivered_fps_min,bytes_per_frame,latency_ms,publish_ms,gather_ms,solver_threads\n";
    }
    if (part != "pipeline") {
      std::vector<int> with_zero{0};
      with_zero.insert(with_zero.end(), counts.begin(), counts.end());
      with_zero.push_back(0);  // again at the end: drift of the machine shows here
      Live(with_zero, seconds, 30, solver_threads, device, csv);
    }
    if (part != "live") {
      Pipeline(dysa::LoadScene("seed_test_scene"), 1.0, 60, counts, Mode::kDecode, seconds, device,
               csv);
      const dysa::Scene block = LargeBlock(large);
      Pipeline(block, 0.1, 30, {1}, Mode::kDecode, seconds, device, csv);
      Pipeline(block, 0.1, 30, {1}, Mode::kReceive, seconds, device, csv);
    }
  }
  if (part == "slowdown" || part == "all") {
    Slowdown(slowdown_subscribers, pairs, window_seconds, 30, solver_threads, device,
             std::filesystem::path(out_dir) / "server_slowdown.csv");
  }
  if (part == "stalled" || part == "all") {
    Stalled(stalled_seconds, device, std::filesystem::path(out_dir) / "server_stalled_memory.csv");
  }
  std::vector<uint64_t> gpu_sizes;
  for (int size : ParseCounts(gpu_sizes_text)) {
    if (size < 1 || uint64_t(size) > dysa::kMaxStreamedParticles) {
      std::fprintf(stderr, "server_bench: error: --gpu-sizes: %d is outside [1, %llu]\n", size,
                   (unsigned long long)dysa::kMaxStreamedParticles);
      return 2;
    }
    gpu_sizes.push_back(uint64_t(size));
  }
  if (part == "gpu" || (part == "all" && device.is_cuda())) {
    std::ofstream csv(std::filesystem::path(out_dir) / "server_gpu.csv");
    csv << "device,particles,subscribers,simulated_fps,delivered_fps,bytes_per_frame,gather_ms,"
           "publish_ms,step_ms,frame_ms,latency_ms,frames,frames_gathered,solver_threads,"
           "device_memory_bytes,target_fps,target_met\n";
    Gpu(gpu_sizes, ParseCounts(gpu_counts_text), seconds, gpu_warmup, solver_threads, device, csv);
  }
  if (part == "gpu_watch") {
    std::ofstream csv(std::filesystem::path(out_dir) / "server_gpu_watch.csv");
    csv << "device,particles,watch_percent,particle_budget,window,watched,frames,steps,"
           "simulated_fps,steps_per_s,gather_ms,publish_ms,delivered_fps,bytes_per_frame\n";
    GpuWatch(gpu_sizes, watch_percent, watch_rounds, seconds, gpu_warmup, solver_threads, device,
             csv);
  }
  return 0;
}
