// The frame contract over real gRPC (docs/server.md, "Paused, the state is a frame"): pauses
// arriving at many points inside frames, for every solver, frames of different lengths, and
// both ways of landing (finishing the frame, or rolling it back to its start), must leave the
// simulation on a frame that
//   - GetStatus and the Pause's reply describe alike (frame, step, time, state hash),
//   - is the last frame a subscriber was sent (frame, step, time),
//   - Step N then StepBack N return to bit for bit (the same state hash).
// Built twice: on the CPU (frame_contract_test) and on cuda:0 (frame_contract_gpu_test, ctest
// label gpu, skipping with the reason where no CUDA GPU can run).
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "dysa/codec/frame_codec.h"
#include "dysa/service/server.h"
#include "dysa/service/simulation_host.h"
#include "dysa/v1/simulation.grpc.pb.h"
#include "support/gpu_test.h"

namespace dysa::service {
namespace {

using Clock = std::chrono::steady_clock;

#ifdef DYSA_FRAME_CONTRACT_ON_CUDA
const Device kDevice = dysa::testing::kGpu;
#define SKIP_WITHOUT_DEVICE() SKIP_WITHOUT_GPU()
#else
const Device kDevice{};
#define SKIP_WITHOUT_DEVICE() \
  do {                        \
  } while (0)
#endif

// 8^3 particles of the thesis's basic set-up, `iterations` fixed steps a frame.
Scene SeedScene(int iterations) {
  Scene scene = LoadScene("seed_basic");
  SetParam(scene.params, "particle_quantity", 8);
  SetParam(scene.params, "spawn_size", 1.2);
  SetParam(scene.params, "iterations_per_frame", iterations);
  return scene;
}

// The GPU tests' dam of 600 particles: tens of CFL steps a frame for wcsph, a few for dfsph.
Scene DamScene(const std::string& solver) { return dysa::testing::DamScene(solver); }

struct Case {
  std::string name;
  Scene (*scene)();
  int landing_budget_ms;  // 0: every pause inside a frame rolls back; 10000: each finishes it
};

std::ostream& operator<<(std::ostream& out, const Case& c) { return out << c.name; }

// The host's log, for counting where the pauses landed.
struct Log {
  std::mutex mu;
  std::vector<std::string> lines;
  int Count(const std::string& text) {
    std::lock_guard lock(mu);
    return int(std::count_if(lines.begin(), lines.end(), [&](const std::string& line) {
      return line.find(text) != line.npos;
    }));
  }
};

// The newest frame a subscriber of the server decoded.
class Subscriber {
 public:
  explicit Subscriber(v1::Simulation::Stub& stub) {
    v1::StreamFramesRequest request;
    request.set_max_fps(0);  // every frame the server sends
    reader_ = stub.StreamFrames(&context_, request);
    thread_ = std::thread([this] { Read(); });
  }
  ~Subscriber() {
    context_.TryCancel();
    thread_.join();
  }

  struct Seen {
    uint64_t frame = 0;
    uint64_t step = 0;
    double time = 0;
  };
  // Waits until the newest frame is at `step` (or 10 s pass) and returns it.
  Seen WaitForStep(uint64_t step) {
    std::unique_lock lock(mu_);
    changed_.wait_for(lock, std::chrono::seconds(10), [&] { return latest_.step == step; });
    return latest_;
  }

 private:
  void Read() {
    codec::FrameDecoder decoder;
    v1::FrameMessage message;
    while (reader_->Read(&message)) {
      for (const std::string& chunk : message.chunks()) {
        auto frame =
            decoder.AddChunk({reinterpret_cast<const uint8_t*>(chunk.data()), chunk.size()});
        if (!frame) continue;
        std::lock_guard lock(mu_);
        latest_ = Seen{message.frame(), frame->step, frame->time};
        changed_.notify_all();
      }
    }
  }

  grpc::ClientContext context_;
  std::unique_ptr<grpc::ClientReader<v1::FrameMessage>> reader_;
  std::mutex mu_;
  std::condition_variable changed_;
  Seen latest_;
  std::thread thread_;
};

std::unique_ptr<grpc::ClientContext> Context() {
  auto context = std::make_unique<grpc::ClientContext>();
  context->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(120));
  return context;
}

class FrameContractTest : public ::testing::TestWithParam<Case> {};

TEST_P(FrameContractTest, APauseInsideAFrameLandsOnAFrameThatStepBackReturnsTo) {
  SKIP_WITHOUT_DEVICE();
  const Case& c = GetParam();
  auto log = std::make_shared<Log>();
  HostOptions options;
  options.device = kDevice;
  options.start_paused = true;
  options.frame_rate = 0;  // as fast as it goes: pauses land anywhere in a frame
  options.solver_threads = 1;
  options.landing_budget = std::chrono::milliseconds(c.landing_budget_ms);
  options.log = [log](const std::string& line) {
    std::lock_guard lock(log->mu);
    log->lines.push_back(line);
  };
  SimulationHost host(c.scene(), options);
  ServerOptions server_options;
  server_options.listen = "127.0.0.1:0";
  Server server(host, server_options);
  auto stub = v1::Simulation::NewStub(grpc::CreateChannel(
      "127.0.0.1:" + std::to_string(server.port()), grpc::InsecureChannelCredentials()));
  Subscriber subscriber(*stub);

  constexpr int kPauses = 8;
  for (int i = 0; i < kPauses; ++i) {
    SCOPED_TRACE("pause " + std::to_string(i));
    v1::ControlReply reply;
    ASSERT_TRUE(stub->Resume(Context().get(), {}, &reply).ok());
    // From at once to a few frames: the pauses fall at different steps of a frame.
    std::this_thread::sleep_for(std::chrono::microseconds(300 * (i % 5)));
    ASSERT_TRUE(stub->Pause(Context().get(), {}, &reply).ok());
    const v1::Status paused = reply.status();
    ASSERT_EQ(paused.state(), v1::RUN_STATE_PAUSED);
    ASSERT_EQ(paused.alarm(), "");
    ASSERT_NE(paused.state_hash(), 0u);

    v1::Status status;
    ASSERT_TRUE(stub->GetStatus(Context().get(), {}, &status).ok());
    EXPECT_EQ(status.frame(), paused.frame());
    EXPECT_EQ(status.step(), paused.step());
    EXPECT_EQ(status.time(), paused.time());
    EXPECT_EQ(status.state_hash(), paused.state_hash());

    const Subscriber::Seen seen = subscriber.WaitForStep(paused.step());
    EXPECT_EQ(seen.step, paused.step()) << "the subscriber was not sent the paused state";
    EXPECT_EQ(seen.frame, paused.frame());
    EXPECT_EQ(seen.time, paused.time());

    const uint32_t n = 2 + i % 3;
    v1::StepRequest step;
    step.set_count(n);
    ASSERT_TRUE(stub->Step(Context().get(), step, &reply).ok());
    ASSERT_EQ(reply.frames_moved(), n);
    v1::StepBackRequest back;
    back.set_count(n);
    ASSERT_TRUE(stub->StepBack(Context().get(), back, &reply).ok());
    EXPECT_EQ(reply.status().frame(), paused.frame());
    EXPECT_EQ(reply.status().step(), paused.step());
    EXPECT_EQ(reply.status().state_hash(), paused.state_hash())
        << "stepping " << n << " frames forward and back did not return to the paused state";
  }
  // The test is about pauses inside frames: some must have landed there, and the way the budget
  // says.
  const int finished = log->Count("finished it");
  const int rolled_back = log->Count("rolled back");
  EXPECT_GT(finished + rolled_back, 0) << "no pause arrived inside a frame";
  if (c.landing_budget_ms == 0) {
    EXPECT_EQ(finished, 0);
  } else {
    EXPECT_EQ(rolled_back, 0);
  }
}

INSTANTIATE_TEST_SUITE_P(
    Solvers, FrameContractTest,
    ::testing::Values(Case{"seed_3_steps_finished", [] { return SeedScene(3); }, 10000},
                      Case{"seed_3_steps_rolled_back", [] { return SeedScene(3); }, 0},
                      Case{"seed_7_steps_rolled_back", [] { return SeedScene(7); }, 0},
                      Case{"wcsph_finished", [] { return DamScene("wcsph"); }, 10000},
                      Case{"wcsph_rolled_back", [] { return DamScene("wcsph"); }, 0},
                      Case{"dfsph_finished", [] { return DamScene("dfsph"); }, 10000},
                      Case{"dfsph_rolled_back", [] { return DamScene("dfsph"); }, 0}),
    [](const ::testing::TestParamInfo<Case>& param) { return param.param.name; });

}  // namespace
}  // namespace dysa::service
