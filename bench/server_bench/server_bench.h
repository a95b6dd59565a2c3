// server_bench's parts (one file each in this folder) and what they share: clients on their own
// connections, the host's options and stages, the test scenes. See bench/server_bench.cc.
#pragma once

#include <grpcpp/grpcpp.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "dysa/core/device.h"
#include "dysa/core/scene.h"
#include "dysa/service/server.h"
#include "dysa/service/simulation_host.h"
#include "dysa/v1/simulation.grpc.pb.h"

namespace server_bench {

using Clock = std::chrono::steady_clock;
using dysa::service::FrameSnapshot;
using dysa::service::HostOptions;
using dysa::service::Server;
using dysa::service::ServerOptions;
using dysa::service::SimulationHost;

double Seconds(Clock::duration d);
int64_t UnixMicros();
double RssMiB();

// One subscriber on its own connection. A decoding client decodes every frame, as a viewer does;
// a receiving client only counts them, standing for a viewer on another machine (its decoding
// then costs the server's cores nothing).
enum class Mode { kStalled, kReceive, kDecode };

class Client {
 public:
  // `request`: the stream's settings (every field at full detail by default; a budget, ...).
  Client(const std::string& address, int index, Mode mode,
         const dysa::v1::StreamFramesRequest& request = {});
  ~Client();
  std::atomic<uint64_t> frames{0};
  std::atomic<uint64_t> bytes{0};
  std::atomic<uint64_t> latency_us{0};  // summed over frames

 private:
  void Read();

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
Delivery Measure(std::vector<std::unique_ptr<Client>>& clients, double seconds);

ServerOptions Loopback();
std::string Address(const Server& server);
// A stub to `server` (Loopback: an insecure channel).
std::unique_ptr<dysa::v1::Simulation::Stub> StubTo(const Server& server);
// Steps the paused host `frames` frames; throws std::runtime_error when the RPC fails.
void StepFrames(dysa::v1::Simulation::Stub& stub, int frames);

// The thesis scene's fluid as a block of n^3 particles: the same spacing (5 m / 44) and
// parameters, in a box scaled to match (as codec_bench does).
dysa::Scene LargeBlock(int n);
// The smallest such block with at least `particles` particles (1,000,000: 100^3; 10,000,000:
// 216^3 = 10,077,696).
dysa::Scene LargeBlockOf(uint64_t particles);

// The mean time per frame of the host's stage `name` (gather_frames, publish_frames), 0 if none.
double StageMs(const dysa::service::HostStatus& status, const std::string& name);

// The live parts' host: paused at first, then simulating as fast as it can.
HostOptions AsFastAsItRuns(int solver_threads, const dysa::Device& device);

// A completed frame and when it was seen.
struct FrameMark {
  uint64_t frame = 0;
  Clock::time_point at;
};

// Waits for the next completed frame (polling: the host has no frame callback) and returns it.
FrameMark NextFrame(SimulationHost& host);

// Calls a control RPC; throws std::runtime_error when it fails.
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

// A host stage's or pass's accumulated time and calls, to difference over a window.
struct StageTotals {
  double step_ms = 0;  // the solver's passes together
  double gather_ms = 0, publish_ms = 0;
  uint64_t gather_calls = 0, publish_calls = 0;
};

StageTotals Totals(const dysa::service::HostStatus& status);

std::vector<int> ParseCounts(const std::string& text);

// The parts (bench/README.md, "Server"): each prints its numbers and writes CSV.
void Live(const std::vector<int>& counts, double seconds, int warmup_frames, int solver_threads,
          const dysa::Device& device, std::ofstream& csv);
void Slowdown(int subscribers, int pairs, double seconds, int warmup_frames, int solver_threads,
              const dysa::Device& device, const std::filesystem::path& out);
void Pipeline(const dysa::Scene& scene, double warmup_time, int recorded,
              const std::vector<int>& counts, Mode mode, double seconds, const dysa::Device& device,
              std::ofstream& csv);
void Stalled(double seconds, const dysa::Device& device, const std::filesystem::path& out);
void Gpu(const std::vector<uint64_t>& sizes, const std::vector<int>& counts, double seconds,
         int warmup_frames, int solver_threads, const dysa::Device& device, std::ofstream& csv);
void GpuWatch(const std::vector<uint64_t>& sizes, double watch_percent, int rounds, double seconds,
              int warmup_frames, int solver_threads, const dysa::Device& device,
              std::ofstream& csv);

}  // namespace server_bench
