// Part 5: a watched run on the GPU (issue "Watch any run from anywhere", item 4: the subset is
// chosen where the particles live, and a watched run slows the simulation by at most 5%). For
// each size, one host on --device (cuda:0 by default) steps a block of the thesis fluid
// (LargeBlockOf, 2 steps a frame) as fast as it runs; after `warmup_frames`, windows of
// `seconds` alternate between no subscriber and one budgeted subscriber (particle_budget:
// `watch_percent` % of the particles), `rounds` watched windows between rounds + 1 unwatched
// ones. The subscriber only receives (a remote viewer: its decoding costs the server's cores
// nothing). Each watched window's step rate is compared with the mean of the two unwatched
// windows around it, which cancels a linear drift of the step's cost as the block falls; the
// median of those ratios is the slowdown. That comparison carries the flow's own changes of
// step cost between windows; beside it, the share of the stepping thread's time the subset
// read took in each watched window (gather ms x frames/s: the read runs on the thread that
// steps, the encoding on the publisher's), whose median is the watching's direct cost. Per window:
// frames, steps, the rates, and the host's gather (a subset read: on a GPU only the kept particles
// cross to the host) and publish times.
#include <algorithm>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "server_bench/server_bench.h"

namespace server_bench {

namespace {

struct Window {
  bool watched = false;
  uint64_t frames = 0, steps = 0;
  double fps = 0, steps_per_s = 0;
  double gather_ms = 0, publish_ms = 0;  // per frame gathered / published in the window
  double delivered_fps = 0, bytes_per_frame = 0;
};

// One window of `seconds` with `client` (null: unwatched) subscribed for the whole of it.
Window RunWindow(SimulationHost& host, Client* client, double seconds) {
  Window w;
  w.watched = client != nullptr;
  const FrameMark begin = NextFrame(host);
  const auto s0 = host.Status();
  const StageTotals t0 = Totals(s0);
  const uint64_t f0 = client ? client->frames.load() : 0;
  const uint64_t b0 = client ? client->bytes.load() : 0;
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  const FrameMark end = NextFrame(host);
  const auto s1 = host.Status();
  const StageTotals t1 = Totals(s1);
  const double elapsed = Seconds(end.at - begin.at);
  w.frames = end.frame - begin.frame;
  w.steps = s1.step - s0.step;
  w.fps = w.frames / elapsed;
  w.steps_per_s = w.steps / elapsed;
  const auto per_call = [](double total, uint64_t calls) { return calls ? total / calls : 0.0; };
  w.gather_ms = per_call(t1.gather_ms - t0.gather_ms, t1.gather_calls - t0.gather_calls);
  w.publish_ms = per_call(t1.publish_ms - t0.publish_ms, t1.publish_calls - t0.publish_calls);
  if (client) {
    const uint64_t frames = client->frames - f0;
    w.delivered_fps = frames / elapsed;
    w.bytes_per_frame = frames ? double(client->bytes - b0) / double(frames) : 0;
  }
  return w;
}

double Median(std::vector<double> values) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const size_t m = values.size();
  return m % 2 ? values[m / 2] : 0.5 * (values[m / 2 - 1] + values[m / 2]);
}

}  // namespace

void GpuWatch(const std::vector<uint64_t>& sizes, double watch_percent, int rounds, double seconds,
              int warmup_frames, int solver_threads, const dysa::Device& device,
              std::ofstream& csv) {
  for (uint64_t requested : sizes) {
    const dysa::Scene scene = LargeBlockOf(requested);
    SimulationHost host(scene, AsFastAsItRuns(solver_threads, device));
    Server server(host, Loopback());
    auto stub = StubTo(server);
    StepFrames(*stub, warmup_frames);
    const uint64_t particles = host.Status().particles;
    dysa::v1::StreamFramesRequest watch;
    const double budget = std::clamp(double(particles) * watch_percent / 100, 1.0, 20e6);
    watch.set_particle_budget(uint32_t(budget));
    Control(*stub, &dysa::v1::Simulation::Stub::Resume, dysa::v1::ResumeRequest{});
    std::string where = host.Status().device;  // "cuda:0 NVIDIA H200, 139.8 GiB, sm_90"
    std::replace(where.begin(), where.end(), ',', ';');

    std::vector<Window> windows;
    for (int k = 0; k < 2 * rounds + 1; ++k) {
      std::unique_ptr<Client> client;
      if (k % 2) {
        client = std::make_unique<Client>(Address(server), k, Mode::kReceive, watch);
        const auto deadline = Clock::now() + std::chrono::seconds(120);
        while (client->frames == 0 && Clock::now() < deadline) {  // its first frame, a keyframe
          std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
      }
      const Window w = RunWindow(host, client.get(), seconds);
      client.reset();
      const auto deadline = Clock::now() + std::chrono::seconds(60);
      while (host.Status().subscribers != 0 && Clock::now() < deadline) {
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
      }
      windows.push_back(w);
      std::printf(
          "gpu_watch %9llu particles  window %2d %-9s: %7.2f frames/s, %8.2f steps/s, gather "
          "%.2f ms, publish %.2f ms, delivered %7.2f frames/s, %10.0f B/frame\n",
          (unsigned long long)particles, k, w.watched ? "watched" : "unwatched", w.fps,
          w.steps_per_s, w.gather_ms, w.publish_ms, w.delivered_fps, w.bytes_per_frame);
      std::fflush(stdout);
      csv << where << "," << particles << "," << watch_percent << "," << uint32_t(budget) << ","
          << k << "," << (w.watched ? 1 : 0) << "," << w.frames << "," << w.steps << "," << w.fps
          << "," << w.steps_per_s << "," << w.gather_ms << "," << w.publish_ms << ","
          << w.delivered_fps << "," << w.bytes_per_frame << "\n";
      csv.flush();
    }
    server.Shutdown();
    std::vector<double> slowdowns, gather_shares;
    for (size_t k = 1; k + 1 < windows.size(); k += 2) {
      const double unwatched = 0.5 * (windows[k - 1].steps_per_s + windows[k + 1].steps_per_s);
      if (unwatched > 0) slowdowns.push_back(1 - windows[k].steps_per_s / unwatched);
      gather_shares.push_back(windows[k].gather_ms * windows[k].fps / 1000);
    }
    const double median = Median(slowdowns);
    std::printf(
        "gpu_watch %9llu particles, a %.3g%% budget (%u particles a frame at most): step rate "
        "slowed by %.1f%% (median of %zu watched windows; target at most 5%%: %s)\n",
        (unsigned long long)particles, watch_percent, uint32_t(budget), 100 * median,
        slowdowns.size(), median <= 0.05 ? "met" : "NOT met");
    std::printf(
        "gpu_watch %9llu particles: the subset read took %.1f%% of the stepping thread's time "
        "(median of the watched windows' gather ms x frames/s)\n",
        (unsigned long long)particles, 100 * Median(gather_shares));
    std::fflush(stdout);
  }
}

}  // namespace server_bench
