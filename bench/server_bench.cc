// Server benchmark: frames delivered to 1, 4 and 16 subscribers, the simulation's slowdown with
// subscribers against none, the pipeline's capacity (encode, gRPC on loopback, decode) for the
// thesis scene and a 1M-particle block, memory with a stalled subscriber over time, and the
// live server with its simulation on a CUDA GPU for blocks of 1M and 10M particles.
//
// Everything runs in this process: the real Server and SimulationHost on a loopback port, and
// clients that each have their own connection and decode every frame, as a viewer does.
//
//   server_bench                       # all parts, results in bench/results/server_*.csv
//   server_bench --part pipeline --large 100 --seconds 5
//   server_bench --part slowdown --slowdown-subscribers 4 --pairs 20 --window 3
//   server_bench --part live --device cuda  # the simulations step on the GPU
//   server_bench --part gpu --gpu-sizes 1000000,10000000   # on cuda:0 unless --device says
#include <grpcpp/grpcpp.h>
#include <omp.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "dysa/codec/frame_codec.h"
#include "dysa/core/device.h"
#include "dysa/core/scene.h"
#include "dysa/core/types.h"
#include "dysa/service/server.h"
#include "dysa/service/simulation_host.h"
#include "dysa/v1/simulation.grpc.pb.h"

namespace {

using Clock = std::chrono::steady_clock;
using dysa::service::FrameSnapshot;
using dysa::service::HostOptions;
using dysa::service::Server;
using dysa::service::ServerOptions;
using dysa::service::SimulationHost;

double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

int64_t UnixMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

double RssMiB() {
  std::ifstream status("/proc/self/status");
  std::string key;
  while (status >> key) {
    if (key == "VmRSS:") {
      double kib = 0;
      status >> kib;
      return kib / 1024;
    }
  }
  return 0;
}

// One subscriber on its own connection. A decoding client decodes every frame, as a viewer does;
// a receiving client only counts them, standing for a viewer on another machine (its decoding
// then costs the server's cores nothing).
enum class Mode { kStalled, kReceive, kDecode };

class Client {
 public:
  Client(const std::string& address, int index, Mode mode) : mode_(mode) {
    grpc::ChannelArguments args;
    args.SetInt("dysa.bench.client", index);  // a distinct argument: a connection of its own
    args.SetMaxReceiveMessageSize(8 << 20);
    channel_ = grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), args);
    stub_ = dysa::v1::Simulation::NewStub(channel_);
    reader_ = stub_->StreamFrames(&context_, dysa::v1::StreamFramesRequest{});
    if (mode != Mode::kStalled) thread_ = std::thread([this] { Read(); });
  }
  ~Client() {
    context_.TryCancel();
    if (thread_.joinable()) thread_.join();
  }
  std::atomic<uint64_t> frames{0};
  std::atomic<uint64_t> bytes{0};
  std::atomic<uint64_t> latency_us{0};  // summed over frames

 private:
  void Read() {
    dysa::codec::FrameDecoder decoder;
    dysa::codec::Frame frame;
    std::vector<dysa::codec::Chunk> chunks;
    dysa::v1::FrameMessage message;
    while (reader_->Read(&message)) {
      for (const std::string& c : message.chunks()) chunks.emplace_back(c.begin(), c.end());
      if (!message.last_of_frame()) continue;
      try {
        if (mode_ == Mode::kReceive || decoder.AddChunks(chunks, frame)) {
          bytes += message.frame_bytes();
          latency_us += uint64_t(std::max<int64_t>(0, UnixMicros() - message.produced_unix_us()));
          ++frames;
        }
      } catch (const dysa::codec::DecodeError& e) {
        std::fprintf(stderr, "decode error: %s\n", e.what());
      }
      chunks.clear();
    }
    reader_->Finish();
  }

  const Mode mode_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<dysa::v1::Simulation::Stub> stub_;
  grpc::ClientContext context_;
  std::unique_ptr<grpc::ClientReader<dysa::v1::FrameMessage>> reader_;
  std::thread thread_;
};

struct Delivery {
  double fps_mean = 0, fps_min = 0, bytes_per_frame = 0, latency_ms = 0;
};

// Frames received by each client over `seconds`, after every client has its first frame.
Delivery Measure(std::vector<std::unique_ptr<Client>>& clients, double seconds) {
  const auto deadline = Clock::now() + std::chrono::seconds(60);
  for (auto& c : clients) {
    while (c->frames == 0 && Clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  }
  std::vector<uint64_t> f0, b0, l0;
  for (auto& c : clients) {
    f0.push_back(c->frames);
    b0.push_back(c->bytes);
    l0.push_back(c->latency_us);
  }
  const auto start = Clock::now();
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  const double elapsed = Seconds(Clock::now() - start);
  Delivery d;
  d.fps_min = 1e30;
  uint64_t frames = 0, bytes = 0, latency = 0;
  for (size_t i = 0; i < clients.size(); ++i) {
    const uint64_t f = clients[i]->frames - f0[i];
    frames += f;
    bytes += clients[i]->bytes - b0[i];
    latency += clients[i]->latency_us - l0[i];
    d.fps_mean += f / elapsed / clients.size();
    d.fps_min = std::min(d.fps_min, f / elapsed);
  }
  d.bytes_per_frame = frames ? double(bytes) / frames : 0;
  d.latency_ms = frames ? latency / 1000.0 / frames : 0;
  return d;
}

ServerOptions Loopback() {
  ServerOptions options;
  options.listen = "127.0.0.1:0";
  return options;
}

std::string Address(const Server& server) { return "127.0.0.1:" + std::to_string(server.port()); }

// The thesis scene's fluid as a block of n^3 particles: the same spacing (5 m / 44) and
// parameters, in a box scaled to match (as codec_bench does).
dysa::Scene LargeBlock(int n) {
  dysa::Scene scene = dysa::LoadScene("seed_test_scene");
  const double size = 5.0 / 44 * (n - 1);
  scene.domain = {dysa::Vec3d::Constant(-size), dysa::Vec3d::Constant(size)};
  scene.params.particle_quantity = n;
  scene.params.spawn_size = size;
  scene.name = "block_" + std::to_string(n) + "^3";
  return scene;
}

// The smallest such block with at least `particles` particles (1,000,000: 100^3; 10,000,000:
// 216^3 = 10,077,696).
dysa::Scene LargeBlockOf(uint64_t particles) {
  int n = std::max(1, int(std::cbrt(double(particles))) - 1);
  while (uint64_t(n) * n * n < particles) ++n;
  return LargeBlock(n);
}

// The mean time per frame of the host's stage `name` (gather_frames, publish_frames), 0 if none.
double StageMs(const dysa::service::HostStatus& status, const std::string& name) {
  for (const auto& pass : status.passes) {
    if (pass.name == name) return pass.mean_ms;
  }
  return 0;
}

// The live parts' host: paused at first, then simulating as fast as it can.
HostOptions AsFastAsItRuns(int solver_threads, const dysa::Device& device) {
  HostOptions options;
  options.device = device;
  options.frame_rate = 0;
  options.start_paused = true;
  options.solver_threads = solver_threads;
  return options;
}

// Part 1: the live simulation as fast as it runs, from the same state each time, with 0, 1, 4
// and 16 subscribers: simulated frames per second and frames delivered to each subscriber.
void Live(const std::vector<int>& counts, double seconds, int warmup_frames, int solver_threads,
          const dysa::Device& device, std::ofstream& csv) {
  const dysa::Scene scene = dysa::LoadScene("seed_test_scene");
  for (int n : counts) {
    SimulationHost host(scene, AsFastAsItRuns(solver_threads, device));
    Server server(host, Loopback());
    auto stub = dysa::v1::Simulation::NewStub(
        grpc::CreateChannel(Address(server), grpc::InsecureChannelCredentials()));
    {
      grpc::ClientContext context;
      dysa::v1::StepRequest step;
      step.set_count(warmup_frames);  // into the splash: the same state for every count
      dysa::v1::ControlReply reply;
      stub->Step(&context, step, &reply);
    }
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

// Part 1b: the simulation's slowdown with `subscribers` against none, measured so that both
// the scene's and the machine's drift cancel. Every window replays the same frames of the
// thesis scene: it starts paused at frame `warmup_frames`, runs as fast as it can for `seconds`,
// pauses and steps back there (the history replays bit-identical frames). Windows alternate
// between no subscriber and `subscribers` of them (2 * pairs + 1 windows, starting and ending
// with none); each subscribed window is compared with the mean of the two unsubscribed windows
// around it, and the median of those ratios is the slowdown. A window's rate is timed from one
// completed frame to another, so it is not rounded to whole frames.
struct FrameMark {
  uint64_t frame = 0;
  Clock::time_point at;
};

// Waits for the next completed frame (polling: the host has no frame callback) and returns it.
FrameMark NextFrame(SimulationHost& host) {
  const uint64_t now = host.Status().frame;
  const auto deadline = Clock::now() + std::chrono::seconds(30);
  while (Clock::now() < deadline) {
    const uint64_t f = host.Status().frame;
    if (f != now) return {f, Clock::now()};
    std::this_thread::sleep_for(std::chrono::microseconds(500));
  }
  return {now, Clock::now()};
}

template <class Request>
void Control(dysa::v1::Simulation::Stub& stub,
             grpc::Status (dysa::v1::Simulation::Stub::*rpc)(grpc::ClientContext*, const Request&,
                                                             dysa::v1::ControlReply*),
             const Request& request) {
  grpc::ClientContext context;
  dysa::v1::ControlReply reply;
  const grpc::Status status = (stub.*rpc)(&context, request, &reply);
  if (!status.ok()) throw std::runtime_error("control RPC failed: " + status.error_message());
}

void Slowdown(int subscribers, int pairs, double seconds, int warmup_frames, int solver_threads,
              const dysa::Device& device, const std::filesystem::path& out) {
  using dysa::v1::Simulation;
  const dysa::Scene scene = dysa::LoadScene("seed_test_scene");
  SimulationHost host(scene, AsFastAsItRuns(solver_threads, device));
  Server server(host, Loopback());
  auto stub =
      Simulation::NewStub(grpc::CreateChannel(Address(server), grpc::InsecureChannelCredentials()));
  dysa::v1::StepRequest warmup;
  warmup.set_count(warmup_frames);
  Control(*stub, &Simulation::Stub::Step, warmup);
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

// Part 2: the delivery pipeline alone. Frames recorded from a real run are published as fast as
// they are encoded (the simulation is paused), so the numbers are the fan-out's capacity:
// encoding, gRPC on loopback and each client's decoding, on the same 2 cores.
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

// Part 3: the thesis scene at 60 frames/s with one subscriber that never reads and one that does:
// resident memory of the whole process, sampled every second.
void Stalled(double seconds, const dysa::Device& device, const std::filesystem::path& out) {
  HostOptions options;
  options.frame_rate = 60;
  options.device = device;
  SimulationHost host(dysa::LoadScene("seed_test_scene"), options);
  Server server(host, Loopback());
  Client stalled(Address(server), 0, Mode::kStalled);
  Client reader(Address(server), 1, Mode::kDecode);
  std::ofstream csv(out);
  csv << "seconds,rss_mib,history_mib,frame,frames_encoded,frames_alive,reader_frames\n";
  const auto start = Clock::now();
  // Memory apart from the step-back history, which grows to its budget by design.
  double first = 0, peak = 0;
  for (int s = 0; s <= int(seconds); ++s) {
    std::this_thread::sleep_until(start + std::chrono::seconds(s));
    const auto status = host.Status();
    const double rss = RssMiB();
    const double other = rss - status.history_bytes / 1048576.0;
    if (s == 5) first = other;
    peak = std::max(peak, other);
    csv << s << "," << rss << "," << status.history_bytes / 1048576.0 << "," << status.frame << ","
        << status.frames_encoded << "," << host.hub().frames_alive() << "," << reader.frames
        << "\n";
    std::printf(
        "stalled   t=%3d s  rss %7.1f MiB  history %6.1f MiB  frame %6llu  frames alive %lld  "
        "reader %llu\n",
        s, rss, status.history_bytes / 1048576.0, (unsigned long long)status.frame,
        (long long)host.hub().frames_alive(), (unsigned long long)reader.frames.load());
    std::fflush(stdout);
  }
  std::printf("stalled   rss less history: at 5 s %.1f MiB, peak %.1f MiB (growth %.1f MiB)\n",
              first, peak, peak - first);
  server.Shutdown();
}

// Part 4: the live server with its simulation on a GPU (issue "The server on the GPU box"). A
// block of the thesis fluid (LargeBlockOf: seed_test_scene's spacing and parameters, 2 steps a
// frame) runs as fast as it can (frame_rate 0) with 0 and 1 subscribers that decode every frame
// on the same machine, as a viewer does; each configuration starts from a freshly spawned block
// `warmup_frames` frames into its fall. The host keeps dysa-server's defaults otherwise
// (history 600 frames / 256 MiB, max_particles 20M). Per configuration: simulated and delivered
// frames/s, bytes per frame, and the host's per-frame stages over the measured window only:
// the solver's step (the sum of its passes, CUDA events on a GPU), gather_frames (the particles
// copied back and put in id order, on the simulation thread) and publish_frames (encoding and
// starting the writes).

// A host stage's or pass's accumulated time and calls, to difference over a window.
struct StageTotals {
  double step_ms = 0;  // the solver's passes together
  double gather_ms = 0, publish_ms = 0;
  uint64_t gather_calls = 0, publish_calls = 0;
};

StageTotals Totals(const dysa::service::HostStatus& status) {
  StageTotals t;
  for (const auto& pass : status.passes) {
    const double total = pass.mean_ms * double(pass.calls);
    if (pass.name == "gather_frames") {
      t.gather_ms = total;
      t.gather_calls = pass.calls;
    } else if (pass.name == "publish_frames") {
      t.publish_ms = total;
      t.publish_calls = pass.calls;
    } else {
      t.step_ms += total;
    }
  }
  return t;
}

// The frame rates the issue asks for: 1M particles at 60 frames/s, 10M at 10; 0 for other sizes.
double GpuTarget(uint64_t requested) {
  if (requested >= 10'000'000) return 10;
  if (requested >= 1'000'000) return 60;
  return 0;
}

void Gpu(const std::vector<uint64_t>& sizes, const std::vector<int>& counts, double seconds,
         int warmup_frames, int solver_threads, const dysa::Device& device, std::ofstream& csv) {
  for (uint64_t requested : sizes) {
    const dysa::Scene scene = LargeBlockOf(requested);
    const double target = GpuTarget(requested);
    for (int n : counts) {
      const auto setup = Clock::now();
      SimulationHost host(scene, AsFastAsItRuns(solver_threads, device));
      Server server(host, Loopback());
      auto stub = dysa::v1::Simulation::NewStub(
          grpc::CreateChannel(Address(server), grpc::InsecureChannelCredentials()));
      dysa::v1::StepRequest warmup;
      warmup.set_count(warmup_frames);
      Control(*stub, &dysa::v1::Simulation::Stub::Step, warmup);
      std::vector<std::unique_ptr<Client>> clients;
      for (int i = 0; i < n; ++i) {
        clients.push_back(std::make_unique<Client>(Address(server), i, Mode::kDecode));
      }
      Control(*stub, &dysa::v1::Simulation::Stub::Resume, dysa::v1::ResumeRequest{});
      // Every client has its first frame (a keyframe) before the window starts; Measure then
      // starts at once.
      const auto deadline = Clock::now() + std::chrono::seconds(120);
      for (auto& c : clients) {
        while (c->frames == 0 && Clock::now() < deadline) {
          std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
      }
      const double setup_s = Seconds(Clock::now() - setup);
      const FrameMark begin = NextFrame(host);
      const StageTotals t0 = Totals(host.Status());
      Delivery d;
      if (n > 0) {
        d = Measure(clients, seconds);
      } else {
        std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
      }
      const FrameMark end = NextFrame(host);
      const auto status = host.Status();
      const StageTotals t1 = Totals(status);
      clients.clear();
      server.Shutdown();

      const uint64_t frames = end.frame - begin.frame;
      const double sim_fps = frames / Seconds(end.at - begin.at);
      const double frame_ms = frames ? 1000.0 / sim_fps : 0;
      const double step_ms = frames ? (t1.step_ms - t0.step_ms) / frames : 0;
      const auto per_call = [](double total, uint64_t calls) { return calls ? total / calls : 0; };
      const double gather_ms =
          per_call(t1.gather_ms - t0.gather_ms, t1.gather_calls - t0.gather_calls);
      const double publish_ms =
          per_call(t1.publish_ms - t0.publish_ms, t1.publish_calls - t0.publish_calls);
      const uint64_t gathered = t1.gather_calls - t0.gather_calls;
      const double delivered = n > 0 ? d.fps_min : 0.0;
      const bool met =
          target > 0 && frames > 0 && sim_fps >= target && (n == 0 || delivered >= target);
      std::printf(
          "gpu       %9u particles  %d subscribers: simulation %7.2f frames/s (%.2f ms a frame, "
          "step %.2f ms), delivered %7.2f frames/s, %10.0f B/frame (%.2f B/particle), latency "
          "%6.1f ms, gather %.2f ms (%llu frames), publish %.2f ms; target %s%s (set-up %.1f s)\n",
          status.particles, n, sim_fps, frame_ms, step_ms, delivered, d.bytes_per_frame,
          status.particles ? d.bytes_per_frame / status.particles : 0.0, d.latency_ms, gather_ms,
          (unsigned long long)gathered, publish_ms,
          target > 0 ? std::to_string(int(target)).c_str() : "none",
          target > 0 ? (met ? " met" : " NOT met") : "", setup_s);
      std::fflush(stdout);
      std::string where = status.device;  // "cuda:0 NVIDIA H200, 139.8 GiB, sm_90"
      std::replace(where.begin(), where.end(), ',', ';');
      csv << where << "," << status.particles << "," << n << "," << sim_fps << "," << delivered
          << "," << d.bytes_per_frame << "," << gather_ms << "," << publish_ms << "," << step_ms
          << "," << frame_ms << "," << d.latency_ms << "," << frames << "," << gathered << ","
          << status.solver_threads << "," << status.device_memory_bytes << ","
          << (target > 0 ? std::to_string(int(target)) : "") << ","
          << (target > 0 ? (met ? "yes" : "no") : "") << "\n";
      csv.flush();
    }
  }
}

std::vector<int> ParseCounts(const std::string& text) {
  std::vector<int> counts;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) counts.push_back(std::stoi(item));
  return counts;
}

}  // namespace

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
                 "live, slowdown, pipeline, stalled, gpu or all (gpu: with a CUDA --device, or "
                 "alone, where it defaults to cuda:0)")
      ->check(CLI::IsMember({"live", "slowdown", "pipeline", "stalled", "gpu", "all"}))
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
  CLI11_PARSE(app, argc, argv);
  // The gpu part steps on the GPU unless --device names a device (cpu: a dry run of the part).
  if (part == "gpu" && app.count("--device") == 0) device_text = "cuda";

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
  if (part == "gpu" || (part == "all" && device.is_cuda())) {
    std::vector<uint64_t> sizes;
    for (int size : ParseCounts(gpu_sizes_text)) {
      if (size < 1 || uint64_t(size) > dysa::kMaxStreamedParticles) {
        std::fprintf(stderr, "server_bench: error: --gpu-sizes: %d is outside [1, %llu]\n", size,
                     (unsigned long long)dysa::kMaxStreamedParticles);
        return 2;
      }
      sizes.push_back(uint64_t(size));
    }
    std::ofstream csv(std::filesystem::path(out_dir) / "server_gpu.csv");
    csv << "device,particles,subscribers,simulated_fps,delivered_fps,bytes_per_frame,gather_ms,"
           "publish_ms,step_ms,frame_ms,latency_ms,frames,frames_gathered,solver_threads,"
           "device_memory_bytes,target_fps,target_met\n";
    Gpu(sizes, ParseCounts(gpu_counts_text), seconds, gpu_warmup, solver_threads, device, csv);
  }
  return 0;
}
