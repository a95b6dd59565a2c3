// Part 1b: the simulation's slowdown with `subscribers` against none, measured so that both
// the scene's and the machine's drift cancel. Every window replays the same frames of the
// thesis scene: it starts paused at frame `warmup_frames`, runs as fast as it can for `seconds`,
// pauses and steps back there (the history replays bit-identical frames). Windows alternate
// between no subscriber and `subscribers` of them (2 * pairs + 1 windows, starting and ending
// with none); each subscribed window is compared with the mean of the two unsubscribed windows
// around it, and the median of those ratios is the slowdown. A window's rate is timed from one
// completed frame to another, so it is not rounded to whole frames.
#include <algorithm>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "server_bench/server_bench.h"

namespace server_bench {

void Slowdown(int subscribers, int pairs, double seconds, int warmup_frames, int solver_threads,
              const dysa::Device& device, const std::filesystem::path& out) {
  using dysa::v1::Simulation;
  const dysa::Scene scene = dysa::LoadScene("seed_test_scene");
  SimulationHost host(scene, AsFastAsItRuns(solver_threads, device));
  Server server(host, Loopback());
  auto stub = StubTo(server);
  StepFrames(*stub, warmup_frames);
  const uint64_t start_frame = host.Status().frame;

  std::ofstream csv(out);
  csv << "window,subscribers,frames,simulated_fps,delivered_fps_min,gather_ms,publish_ms\n";
  std::vector<double> fps;
  // Window -1, not counted, has subscribers: gRPC's first connections and threads start there.
  for (int w = -1; w < 2 * pairs + 1; ++w) {
    const int n = w % 2 ? subscribers : 0;
    std::vector<std::unique_ptr<Client>> clients;
    for (int i = 0; i < n; ++i) {
      clients.push_back(std::make_unique<Client>(Address(server), i, Mode::kReceive));
    }
    const auto deadline = Clock::now() + std::chrono::seconds(60);
    for (auto& c : clients) {  // a paused host sends joiners the current frame
      while (c->frames == 0 && Clock::now() < deadline) {
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
      }
    }
    Control(*stub, &Simulation::Stub::Resume, dysa::v1::ResumeRequest{});
    const FrameMark begin = NextFrame(host);
    std::vector<uint64_t> received0;
    for (auto& c : clients) received0.push_back(c->frames);
    std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
    const FrameMark end = NextFrame(host);
    const double elapsed = Seconds(end.at - begin.at);
    double delivered_min = 0;
    for (size_t i = 0; i < clients.size(); ++i) {
      const double d = (clients[i]->frames - received0[i]) / elapsed;
      delivered_min = i == 0 ? d : std::min(delivered_min, d);
    }
    Control(*stub, &Simulation::Stub::Pause, dysa::v1::PauseRequest{});
    const auto status = host.Status();
    clients.clear();
    while (host.Status().subscribers != 0 && Clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    dysa::v1::StepBackRequest back;
    back.set_count(uint32_t(status.frame - start_frame));
    Control(*stub, &Simulation::Stub::StepBack, back);
    if (w < 0) continue;
    fps.push_back((end.frame - begin.frame) / elapsed);
    std::printf("slowdown  window %2d  %2d subscribers: simulation %6.2f frames/s\n", w, n,
                fps.back());
    csv << w << "," << n << "," << (end.frame - begin.frame) << "," << fps.back() << ","
        << delivered_min << "," << StageMs(status, "gather_frames") << ","
        << StageMs(status, "publish_frames") << "\n";
  }
  std::vector<double> ratios;
  for (int w = 1; w < 2 * pairs + 1; w += 2) {
    ratios.push_back(1 - fps[w] / (0.5 * (fps[w - 1] + fps[w + 1])));
  }
  std::vector<double> sorted = ratios;
  std::sort(sorted.begin(), sorted.end());
  const size_t m = sorted.size();
  const double median = m % 2 ? sorted[m / 2] : 0.5 * (sorted[m / 2 - 1] + sorted[m / 2]);
  double mean = 0;
  for (double r : ratios) mean += r / m;
  std::printf(
      "slowdown with %d subscribers against none, %zu pairs of %.1f s windows: median %.1f%%, "
      "mean %.1f%%, range %.1f%% to %.1f%% (%u solver threads)\n",
      subscribers, m, seconds, 100 * median, 100 * mean, 100 * sorted.front(), 100 * sorted.back(),
      host.Status().solver_threads);
  server.Shutdown();
}

}  // namespace server_bench
