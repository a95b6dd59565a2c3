// Part 5: a watched run on the GPU (issue "Watch any run from anywhere", item 4: the subset is
// chosen where the particles live, and a watched run slows the simulation by at most 5%). For
// each size, one host on --device (cuda:0 by default) steps a block of the thesis fluid
// (LargeBlockOf, 2 steps a frame) as fast as it runs. Every window replays the same frames: the
// host is reset (the block re-spawned at rest: the same bits every time), runs from frame
// kSkippedFrames to kSkippedFrames + N as fast as it can and is paused again, so watched and
// unwatched windows do the same work and only the watching differs. N is what an uncounted
// first window (with a subscriber: gRPC's first connection and threads start there) covers in
// `seconds`. Windows alternate between no subscriber and one budgeted subscriber
// (particle_budget: `watch_percent` % of the particles), `rounds` watched windows between
// rounds + 1 unwatched ones; each watched window's time is compared with the mean of the two
// unwatched windows around it, and the median of those ratios is the slowdown. The subscriber
// only receives (a remote viewer: its decoding costs the server's cores nothing). Beside it, the
// share of the stepping thread's time the subset read took in each watched window (gather ms x
// frames/s: the read runs on the thread that steps, the encoding on the publisher's). Per window:
// frames, steps, the rates, and the host's gather (a subset read: on a GPU only the kept particles
// cross to the host) and publish times.
#include <algorithm>
#include <cstdio>
#include <stdexcept>
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

// The frames a window skips after the reset before its clock starts (the first frame after a
// reset is a keyframe for every subscriber; a watched window's client joins while paused).
constexpr uint64_t kSkippedFrames = 2;

// Waits until the host has completed frame `frame` (polling: the host has no frame callback).
FrameMark WaitForFrame(SimulationHost& host, uint64_t frame) {
  const auto deadline = Clock::now() + std::chrono::seconds(300);
  while (Clock::now() < deadline) {
    const uint64_t f = host.Status().frame;
    if (f >= frame) return {f, Clock::now()};
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  throw std::runtime_error("gpu_watch: frame " + std::to_string(frame) + " not reached in 300 s");
}

// One window: from a reset, with `client` (null: unwatched) subscribed, frames kSkippedFrames to
// kSkippedFrames + `frames` timed (frames 0: for `seconds` instead, the calibrating window).
Window RunWindow(SimulationHost& host, dysa::v1::Simulation::Stub& stub, Client* client,
                 uint64_t frames, double seconds) {
  Window w;
  w.watched = client != nullptr;
  Control(stub, &dysa::v1::Simulation::Stub::Resume, dysa::v1::ResumeRequest{});
  const FrameMark begin = WaitForFrame(host, kSkippedFrames);
  const auto s0 = host.Status();
  const StageTotals t0 = Totals(s0);
  const uint64_t f0 = client ? client->frames.load() : 0;
  const uint64_t b0 = client ? client->bytes.load() : 0;
  FrameMark end;
  if (frames > 0) {
    end = WaitForFrame(host, begin.frame + frames);
  } else {
    std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
    end = NextFrame(host);
  }
  const auto s1 = host.Status();
  Control(stub, &dysa::v1::Simulation::Stub::Pause, dysa::v1::PauseRequest{});
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
    const uint64_t received = client->frames - f0;
    w.delivered_fps = received / elapsed;
    w.bytes_per_frame = received ? double(client->bytes - b0) / double(received) : 0;
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
    std::string where = host.Status().device;  // "cuda:0 NVIDIA H200, 139.8 GiB, sm_90"
    std::replace(where.begin(), where.end(), ',', ';');

    std::vector<Window> windows;
    uint64_t frames = 0;  // each counted window's length, from the calibrating window
    for (int k = -1; k < 2 * rounds + 1; ++k) {
      Control(*stub, &dysa::v1::Simulation::Stub::Reset, dysa::v1::ResetRequest{});
      std::unique_ptr<Client> client;
      if (k % 2) {  // k = -1 too
        client = std::make_unique<Client>(Address(server), k, Mode::kReceive, watch);
        const auto deadline = Clock::now() + std::chrono::seconds(120);
        // A paused host sends a joiner its frame, a keyframe.
        while (client->frames == 0 && Clock::now() < deadline) {
          std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
      }
      const Window w = RunWindow(host, *stub, client.get(), frames, seconds);
      client.reset();
      const auto deadline = Clock::now() + std::chrono::seconds(60);
      while (host.Status().subscribers != 0 && Clock::now() < deadline) {
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
      }
      if (k < 0) {
        frames = std::max<uint64_t>(w.frames, 4);
        continue;
      }
      windows.push_back(w);
      std::printf(
          "gpu_watch %9llu particles  window %2d %-9s: frames %llu-%llu after a reset in %.3f s: "
          "%7.2f frames/s, %8.2f steps/s, gather %.2f ms, publish %.2f ms, delivered %7.2f "
          "frames/s, %10.0f B/frame\n",
          (unsigned long long)particles, k, w.watched ? "watched" : "unwatched",
          (unsigned long long)kSkippedFrames, (unsigned long long)(kSkippedFrames + w.frames),
          w.frames / w.fps, w.fps, w.steps_per_s, w.gather_ms, w.publish_ms, w.delivered_fps,
          w.bytes_per_frame);
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
        "slowed by %.1f%% (median of %zu watched windows, each the same frames as its unwatched "
        "neighbours; target at most 5%%: %s)\n",
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
