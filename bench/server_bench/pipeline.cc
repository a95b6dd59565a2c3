// Part 2: the delivery pipeline alone. Frames recorded from a real run are published as fast as
// they are encoded (the simulation is paused), so the numbers are the fan-out's capacity:
// encoding, gRPC on loopback and each client's decoding, on the same 2 cores.
#include <algorithm>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "dysa/codec/frame_codec.h"
#include "dysa/service/frame_publisher.h"
#include "server_bench/server_bench.h"

namespace server_bench {

void Pipeline(const dysa::Scene& scene, double warmup_time, int recorded,
              const std::vector<int>& counts, Mode mode, double seconds, const dysa::Device& device,
              std::ofstream& csv) {
  std::printf("recording %d frames of %s ...\n", recorded, scene.name.c_str());
  std::vector<FrameSnapshot> frames(recorded);
  {
    dysa::Simulation sim(scene, device);
    while (sim.time() < warmup_time) sim.StepFrame();
    for (FrameSnapshot& f : frames) {
      sim.StepFrame();
      dysa::service::GatherSnapshot(sim, dysa::codec::kPositions | dysa::codec::kSpeed, 0, f);
    }
  }
  for (int n : counts) {
    HostOptions options;
    options.start_paused = true;
    options.device = device;
    SimulationHost host(scene, options);
    // The feeder below is the only publisher: keyframe requests are served by its next frame.
    host.hub().set_frame_needed([] {});
    Server server(host, Loopback());
    std::atomic<bool> stop{false};
    std::atomic<uint64_t> published{0};
    std::thread feeder([&] {
      for (size_t k = 0; !stop; ++k) {
        FrameSnapshot& f = frames[k % frames.size()];
        f.produced_unix_us = UnixMicros();
        host.hub().Publish(f, false, k % frames.size() == 0);
        ++published;
        if (host.hub().subscribers() == 0)
          std::this_thread::sleep_for(std::chrono::milliseconds(1));
      }
    });
    std::vector<std::unique_ptr<Client>> clients;
    for (int i = 0; i < n; ++i)
      clients.push_back(std::make_unique<Client>(Address(server), i, mode));
    const uint64_t p0 = published;
    const auto start = Clock::now();
    const Delivery d = Measure(clients, seconds);
    const double publish_fps = (published - p0) / Seconds(Clock::now() - start);
    clients.clear();
    stop = true;
    feeder.join();
    const char* part = mode == Mode::kDecode ? "pipeline" : "pipeline_receive_only";
    std::printf(
        "%s  %-14s %8zu particles  %2d subscribers: encoded %6.2f frames/s, "
        "delivered %6.2f (min %6.2f) frames/s, %8.0f B/frame, latency %6.1f ms\n",
        part, scene.name.c_str(), frames[0].positions.size() / 3, n, publish_fps, d.fps_mean,
        d.fps_min, d.bytes_per_frame, d.latency_ms);
    csv << part << "," << scene.name << "," << frames[0].positions.size() / 3 << "," << n << ","
        << publish_fps << "," << d.fps_mean << "," << d.fps_min << "," << d.bytes_per_frame << ","
        << d.latency_ms << ",,,\n";
    csv.flush();
    server.Shutdown();
  }
}

}  // namespace server_bench
