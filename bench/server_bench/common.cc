// What server_bench's parts share (server_bench.h).
#include <algorithm>
#include <cmath>
#include <sstream>

#include "dysa/codec/frame_codec.h"
#include "server_bench/server_bench.h"

namespace server_bench {

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

Client::Client(const std::string& address, int index, Mode mode,
               const dysa::v1::StreamFramesRequest& request)
    : mode_(mode) {
  grpc::ChannelArguments args;
  args.SetInt("dysa.bench.client", index);  // a distinct argument: a connection of its own
  args.SetMaxReceiveMessageSize(8 << 20);
  channel_ = grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), args);
  stub_ = dysa::v1::Simulation::NewStub(channel_);
  reader_ = stub_->StreamFrames(&context_, request);
  if (mode != Mode::kStalled) thread_ = std::thread([this] { Read(); });
}

Client::~Client() {
  context_.TryCancel();
  if (thread_.joinable()) thread_.join();
}

void Client::Read() {
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

std::unique_ptr<dysa::v1::Simulation::Stub> StubTo(const Server& server) {
  return dysa::v1::Simulation::NewStub(
      grpc::CreateChannel(Address(server), grpc::InsecureChannelCredentials()));
}

void StepFrames(dysa::v1::Simulation::Stub& stub, int frames) {
  dysa::v1::StepRequest step;
  step.set_count(frames);
  Control(stub, &dysa::v1::Simulation::Stub::Step, step);
}

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

std::vector<int> ParseCounts(const std::string& text) {
  std::vector<int> counts;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) counts.push_back(std::stoi(item));
  return counts;
}

}  // namespace server_bench
