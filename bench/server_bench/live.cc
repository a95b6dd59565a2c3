// Part 1: the live simulation as fast as it runs, from the same state each time, with 0, 1, 4
// and 16 subscribers: simulated frames per second and frames delivered to each subscriber.
#include <algorithm>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "server_bench/server_bench.h"

namespace server_bench {

void Live(const std::vector<int>& counts, double seconds, int warmup_frames, int solver_threads,
          const dysa::Device& device, std::ofstream& csv) {
  const dysa::Scene scene = dysa::LoadScene("seed_test_scene");
  for (int n : counts) {
    SimulationHost host(scene, AsFastAsItRuns(solver_threads, device));
    Server server(host, Loopback());
    auto stub = StubTo(server);
    StepFrames(*stub, warmup_frames);  // into the splash: the same state for every count
    std::vector<std::unique_ptr<Client>> clients;
    for (int i = 0; i < n; ++i) {
      clients.push_back(std::make_unique<Client>(Address(server), i, Mode::kReceive));
    }
    {
      grpc::ClientContext context;
      dysa::v1::ControlReply reply;
      stub->Resume(&context, {}, &reply);
    }
    const uint64_t frame0 = host.Status().frame;
    const auto start = Clock::now();
    Delivery d;
    if (n > 0) {
      d = Measure(clients, seconds);
    } else {
      std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
    }
    const auto status = host.Status();
    const double sim_fps = (status.frame - frame0) / Seconds(Clock::now() - start);
    const double gather_ms = StageMs(status, "gather_frames");
    const double publish_ms = StageMs(status, "publish_frames");
    std::printf(
        "live      thesis  %8d particles  %2d subscribers, %u solver threads: simulation %6.2f "
        "frames/s, delivered %6.2f (min %6.2f) frames/s, %8.0f B/frame, latency %6.1f ms, gather "
        "%.2f ms, publish %.2f ms\n",
        int(status.particles), n, status.solver_threads, sim_fps, d.fps_mean, n ? d.fps_min : 0.0,
        d.bytes_per_frame, d.latency_ms, gather_ms, publish_ms);
    csv << "live,seed_test_scene," << host.Status().particles << "," << n << "," << sim_fps << ","
        << d.fps_mean << "," << (n ? d.fps_min : 0.0) << "," << d.bytes_per_frame << ","
        << d.latency_ms << "," << publish_ms << "," << gather_ms << "," << status.solver_threads
        << "\n";
    csv.flush();
    clients.clear();
    server.Shutdown();
  }
}

}  // namespace server_bench
