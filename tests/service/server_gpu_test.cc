// dysa-server's service with its simulation on a CUDA GPU (HostOptions::device cuda:0), over
// real gRPC on a free loopback port: step back on the GPU (checkpoints downloaded from device
// memory, restored into it, and frames re-simulated there) lands on the states of the first
// pass bit for bit, for the seed and wcsph solvers; GetStatus names the GPU; frames gathered
// from the GPU stream the simulation's particles in id order, and a budgeted stream's subset is
// chosen on the GPU (only its particles read); a scene whose solver has no GPU backend is
// refused naming the device, and the old scene runs on. ctest label `gpu`: every test skips,
// printing why, where no CUDA GPU can run (a build without CUDA, no driver, no GPU).
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "dysa/codec/detail_subset.h"
#include "dysa/codec/frame_codec.h"
#include "dysa/core/device.h"
#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "dysa/service/frame_publisher.h"
#include "dysa/service/server.h"
#include "dysa/service/simulation_host.h"
#include "dysa/v1/simulation.grpc.pb.h"
#include "support/gpu_test.h"
#include "support/in_process_server.h"

namespace dysa::service {
namespace {

using dysa::testing::kGpu;
using v1::Simulation;

// 10^3 particles of the thesis's basic set-up (3 steps a frame).
Scene SeedScene() {
  Scene scene = LoadScene("seed_basic");
  SetParam(scene.params, "particle_quantity", 10);
  SetParam(scene.params, "spawn_size", 1.2);
  return scene;
}

// The GPU tests' dam of 10 x 15 x 4 particles breaking past a sphere and a box (tens of CFL
// steps a frame).
Scene WcsphScene() {
  Scene scene = dysa::testing::DamScene("wcsph");
  scene.name = "wcsph_dam";
  return scene;
}

// The dam as dfsph runs it.
constexpr const char* kDfsphScene = R"({
  "name": "dfsph_dam",
  "domain": {"min": [0, 0, 0], "max": [0.6, 0.4, 0.08]},
  "fluid_blocks": [{"center": [0.1, 0.15, 0.04], "size": [0.2, 0.3, 0.08]}],
  "solver": "dfsph",
  "params": {"gravity": -9.81, "particle_spacing": 0.02}
})";

// The host's log lines, kept for the test to read (the host logs from its own thread).
struct LogLines {
  std::mutex mu;
  std::vector<std::string> lines;
  bool Contains(const std::string& text) {
    std::lock_guard lock(mu);
    return std::any_of(lines.begin(), lines.end(),
                       [&](const std::string& line) { return line.find(text) != line.npos; });
  }
};

// A paused host on cuda:0 whose history keeps a checkpoint every 4 frames (a budget of 1 MiB
// against 600 frames; max_interval 4), so a step back restores a checkpoint from device memory
// and re-simulates up to 3 frames on the GPU.
HostOptions GpuOptions(const std::shared_ptr<LogLines>& log) {
  HostOptions options;
  options.device = kGpu;
  options.start_paused = true;
  options.history.frames = 600;
  options.history.max_bytes = size_t{1} << 20;
  options.history.max_interval = 4;
  options.log = [log](const std::string& line) {
    std::lock_guard lock(log->mu);
    log->lines.push_back(line);
  };
  return options;
}

// A host and a server on a free port, and a client stub.
class Fixture {
 public:
  Fixture(Scene scene, HostOptions options) {
    ServerOptions server_options;
    server_options.listen = "127.0.0.1:0";
    host_ = std::make_unique<SimulationHost>(std::move(scene), std::move(options));
    server_ = std::make_unique<Server>(*host_, server_options);
    stub_ = Simulation::NewStub(grpc::CreateChannel(address(), grpc::InsecureChannelCredentials()));
  }
  ~Fixture() {
    server_.reset();
    host_.reset();
  }
  std::string address() const { return "127.0.0.1:" + std::to_string(server_->port()); }
  Simulation::Stub& stub() { return *stub_; }

 private:
  std::unique_ptr<SimulationHost> host_;
  std::unique_ptr<Server> server_;
  std::unique_ptr<Simulation::Stub> stub_;
};

std::unique_ptr<grpc::ClientContext> Context() {
  auto context = std::make_unique<grpc::ClientContext>();
  context->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(120));
  return context;
}

v1::Status GetStatus(Simulation::Stub& stub) {
  v1::Status status;
  EXPECT_TRUE(stub.GetStatus(Context().get(), {}, &status).ok());
  return status;
}

v1::ControlReply Step(Simulation::Stub& stub, uint32_t count) {
  v1::StepRequest request;
  request.set_count(count);
  v1::ControlReply reply;
  const grpc::Status s = stub.Step(Context().get(), request, &reply);
  EXPECT_TRUE(s.ok()) << s.error_message();
  return reply;
}

// Steps 10 frames one at a time, steps back 7 (to frame 3: the checkpoint of frame 0 restored,
// frames 1-3 re-simulated), forward again one at a time, then back 5 and forward 5 in one call
// each: every state hash (StateHash of the state downloaded from the GPU, paused) equals the
// first pass's at the same frame.
void ExpectStepBackReplaysTheFirstPass(Simulation::Stub& stub) {
  std::vector<uint64_t> first;
  for (int f = 1; f <= 10; ++f) {
    const v1::ControlReply reply = Step(stub, 1);
    ASSERT_EQ(reply.status().frame(), uint64_t(f));
    ASSERT_EQ(reply.status().alarm(), "");
    first.push_back(reply.status().state_hash());
    ASSERT_NE(first.back(), 0u);
    if (f > 1) {
      ASSERT_NE(first.back(), first[f - 2]) << "frame " << f << ": nothing moved";
    }
  }
  v1::StepBackRequest back;
  back.set_count(7);
  v1::ControlReply reply;
  ASSERT_TRUE(stub.StepBack(Context().get(), back, &reply).ok());
  EXPECT_EQ(reply.frames_moved(), 7u);
  EXPECT_EQ(reply.status().frame(), 3u);
  EXPECT_EQ(reply.status().state_hash(), first[2]) << "frame 3, re-simulated on the GPU";
  for (int f = 4; f <= 10; ++f) {
    reply = Step(stub, 1);
    ASSERT_EQ(reply.status().frame(), uint64_t(f));
    EXPECT_EQ(reply.status().state_hash(), first[f - 1]) << "frame " << f << ", second pass";
  }
  back.set_count(5);
  ASSERT_TRUE(stub.StepBack(Context().get(), back, &reply).ok());
  EXPECT_EQ(reply.status().frame(), 5u);
  EXPECT_EQ(reply.status().state_hash(), first[4]) << "frame 5, re-simulated from frame 4";
  reply = Step(stub, 5);
  EXPECT_EQ(reply.frames_moved(), 5u);
  EXPECT_EQ(reply.status().frame(), 10u);
  EXPECT_EQ(reply.status().state_hash(), first[9]) << "frame 10, third pass";
}

TEST(ServerGpuTest, SeedStepBackOnTheGpuReplaysTheFirstPassBitForBit) {
  SKIP_WITHOUT_GPU();
  auto log = std::make_shared<LogLines>();
  Fixture fx(SeedScene(), GpuOptions(log));
  ASSERT_TRUE(log->Contains("a checkpoint every 4)")) << "the history does not re-simulate";
  ExpectStepBackReplaysTheFirstPass(fx.stub());
}

TEST(ServerGpuTest, WcsphStepBackOnTheGpuReplaysTheFirstPassBitForBit) {
  SKIP_WITHOUT_GPU();
  auto log = std::make_shared<LogLines>();
  Fixture fx(WcsphScene(), GpuOptions(log));
  ASSERT_TRUE(log->Contains("a checkpoint every 4)")) << "the history does not re-simulate";
  EXPECT_EQ(GetStatus(fx.stub()).solver(), "wcsph");
  ExpectStepBackReplaysTheFirstPass(fx.stub());
}

TEST(ServerGpuTest, GetStatusNamesTheGpu) {
  SKIP_WITHOUT_GPU();
  auto log = std::make_shared<LogLines>();
  Fixture fx(SeedScene(), GpuOptions(log));
  const v1::Status status = GetStatus(fx.stub());
  const std::string described = QueryDevice(kGpu).Describe(kGpu);
  EXPECT_EQ(status.device().rfind("cuda:0 ", 0), 0u) << status.device();
  EXPECT_EQ(status.device(), described);  // "cuda:0 NVIDIA H200, 139.8 GiB, sm_90"
  EXPECT_GT(status.device_memory_bytes(), 0u);
  EXPECT_EQ(status.particles(), 1000u);
  EXPECT_TRUE(log->Contains("on " + described)) << "the scene's log line names the GPU";
  // The GPU's passes report their times (CUDA events) as the CPU's do.
  const v1::ControlReply reply = Step(fx.stub(), 2);
  ASSERT_GT(reply.status().passes_size(), 0);
  EXPECT_EQ(reply.status().passes(0).name(), "external_forces");
  EXPECT_EQ(reply.status().passes(0).calls(), 2u * 3);
}

// A subscriber of the GPU server gets the frame the GPU computed, in particle-id order: the same
// particles (to the codec's quantisation, and float rounding should the GPU's sums ever differ
// from the CPU's in the last bit) as the same frames simulated on the CPU.
TEST(ServerGpuTest, FramesStreamTheGpuStateInIdOrder) {
  SKIP_WITHOUT_GPU();
  auto log = std::make_shared<LogLines>();
  Fixture fx(SeedScene(), GpuOptions(log));
  Step(fx.stub(), 5);
  dysa::Simulation cpu(SeedScene());
  for (int f = 0; f < 5; ++f) cpu.StepFrame();

  v1::StreamFramesRequest request;
  request.add_fields(v1::FIELD_VELOCITY);
  request.add_fields(v1::FIELD_DENSITY);
  request.set_position_bits(24);
  request.set_velocity_bits(16);
  auto context = Context();
  auto reader = fx.stub().StreamFrames(context.get(), request);
  // A late joiner of a paused host: frame 5.
  const std::optional<codec::Frame> frame = dysa::testing::FirstFrame(*reader);
  context->TryCancel();
  ASSERT_TRUE(frame.has_value());
  EXPECT_EQ(frame->step, cpu.step());
  ASSERT_EQ(frame->count, 1000u);
  ASSERT_EQ(frame->positions.size(), 3u * 1000);
  ASSERT_EQ(frame->velocities.size(), 3u * 1000);
  ASSERT_EQ(frame->densities.size(), 1000u);
  const ParticleArrays& p = cpu.state().particles;
  const auto near = [](float decoded, float expected, double quantum) {
    return std::abs(double(decoded) - double(expected)) <=
           quantum + 1e-4 * std::abs(double(expected)) + 1e-6;
  };
  for (size_t i = 0; i < p.size(); ++i) {
    const size_t k = p.id[i];
    for (int a = 0; a < 3; ++a) {
      ASSERT_TRUE(near(frame->positions[3 * k + a], p.position[i][a], frame->position_error[a]))
          << "particle " << k << " axis " << a << ": " << frame->positions[3 * k + a] << " vs "
          << p.position[i][a];
      ASSERT_TRUE(near(frame->velocities[3 * k + a], p.velocity[i][a], frame->velocity_error))
          << "particle " << k << " axis " << a << ": " << frame->velocities[3 * k + a] << " vs "
          << p.velocity[i][a];
    }
    ASSERT_TRUE(near(frame->densities[k], p.density[i], frame->density_error))
        << "particle " << k << ": " << frame->densities[k] << " vs " << p.density[i];
  }
}

// A budgeted stream's snapshot on the GPU holds exactly the particles its detail sends, chosen
// on the device, with the bits of a full read of the GPU's state, and the same particles as the
// CPU's snapshot; the others are not written.
TEST(ServerGpuTest, TheSnapshotOfABudgetedStreamIsChosenOnTheGpu) {
  SKIP_WITHOUT_GPU();
  dysa::Simulation gpu(SeedScene(), kGpu);
  dysa::Simulation cpu(SeedScene());
  for (int f = 0; f < 5; ++f) gpu.StepFrame(), cpu.StepFrame();
  const size_t n = gpu.particle_count();
  std::vector<float> positions(3 * n), velocities(3 * n), densities(n);
  gpu.ReadParticlesById({positions, velocities, densities});
  const uint32_t threshold = codec::DetailThreshold(0.2);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const uint32_t fields = codec::kPositions | codec::kVelocity | codec::kDensity;
  FrameSnapshot on_gpu, on_cpu;
  for (FrameSnapshot* s : {&on_gpu, &on_cpu}) {
    s->positions.assign(3 * n, nan);
    s->velocities.assign(3 * n, nan);
    s->densities.assign(n, nan);
  }
  GatherSnapshot(gpu, fields, threshold, on_gpu);
  GatherSnapshot(cpu, fields, threshold, on_cpu);
  EXPECT_EQ(on_gpu.threshold, threshold);
  const std::vector<uint32_t> kept = codec::KeptIds(n, 1, threshold);
  std::vector<bool> keeps(n, false);
  for (uint32_t id : kept) keeps[id] = true;
  for (size_t k = 0; k < n; ++k) {
    for (int a = 0; a < 3; ++a) {
      const size_t e = 3 * k + size_t(a);
      ASSERT_EQ(std::isnan(on_gpu.positions[e]), !keeps[k]) << "particle " << k;
      ASSERT_EQ(std::isnan(on_cpu.positions[e]), !keeps[k]) << "particle " << k;
      if (!keeps[k]) continue;
      ASSERT_EQ(on_gpu.positions[e], positions[e]) << "particle " << k;
      ASSERT_EQ(on_gpu.velocities[e], velocities[e]) << "particle " << k;
    }
    ASSERT_EQ(std::isnan(on_gpu.densities[k]), !keeps[k]) << "particle " << k;
    if (keeps[k]) {
      ASSERT_EQ(on_gpu.densities[k], densities[k]) << "particle " << k;
    }
  }
}

// A budgeted subscriber of the GPU server gets a subset (the particles of its detail threshold)
// of the frame the GPU computed.
TEST(ServerGpuTest, BudgetedFramesStreamTheGpuSubset) {
  SKIP_WITHOUT_GPU();
  auto log = std::make_shared<LogLines>();
  Fixture fx(SeedScene(), GpuOptions(log));
  Step(fx.stub(), 5);
  dysa::Simulation cpu(SeedScene());
  for (int f = 0; f < 5; ++f) cpu.StepFrame();
  const size_t n = cpu.particle_count();
  std::vector<float> positions(3 * n);
  cpu.ReadParticlesById({positions, {}, {}});

  v1::StreamFramesRequest request;
  request.set_particle_budget(200);
  request.set_position_bits(24);
  auto context = Context();
  auto reader = fx.stub().StreamFrames(context.get(), request);
  const std::optional<codec::Frame> frame = dysa::testing::FirstFrame(*reader);
  context->TryCancel();
  ASSERT_TRUE(frame.has_value());
  EXPECT_EQ(frame->step, cpu.step());
  ASSERT_NE(frame->detail_threshold, 0u);
  EXPECT_GT(frame->count, 100u);
  EXPECT_LE(frame->count, 200u);
  EXPECT_EQ(frame->ids, codec::KeptIds(n, 1, frame->detail_threshold));
  ASSERT_EQ(frame->positions.size(), 3u * frame->count);
  for (size_t j = 0; j < frame->ids.size(); ++j) {
    const size_t k = frame->ids[j];
    for (int a = 0; a < 3; ++a) {
      const double expected = positions[3 * k + size_t(a)];
      EXPECT_NEAR(frame->positions[3 * j + size_t(a)], expected,
                  frame->position_error[a] + 1e-4 * std::abs(expected) + 1e-6)
          << "particle " << k << " axis " << a;
    }
  }
}

TEST(ServerGpuTest, DfsphLoadedIntoAGpuServerStepsBackBitForBit) {
  SKIP_WITHOUT_GPU();
  auto log = std::make_shared<LogLines>();
  Fixture fx(SeedScene(), GpuOptions(log));
  Step(fx.stub(), 2);
  v1::LoadSceneRequest load;
  load.set_json_text(kDfsphScene);
  v1::ControlReply reply;
  ASSERT_TRUE(fx.stub().LoadScene(Context().get(), load, &reply).ok());
  const v1::Status status = GetStatus(fx.stub());
  EXPECT_EQ(status.solver(), "dfsph");
  EXPECT_EQ(status.frame(), 0u);
  EXPECT_EQ(status.device().rfind("cuda:0 ", 0), 0u) << status.device();
  // The checkpoints carry dfsph's warm start: re-simulated frames match the first pass.
  ExpectStepBackReplaysTheFirstPass(fx.stub());
}

}  // namespace
}  // namespace dysa::service
