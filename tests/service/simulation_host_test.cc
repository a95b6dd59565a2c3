// Tests of dysa/service/simulation_host.h, without a network: controls are applied between
// steps with the documented results (a Step yields to later controls, a frame interrupted by a
// control goes on bit-identically), controls whose caller gave up are not applied, invalid
// changes apply nothing, limits are enforced, and stepping back and forward again reaches
// bit-identical states.
#include "dysa/service/simulation_host.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <future>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "service/simulation_host_scenes.h"

namespace dysa::service {
namespace {

ControlResult Apply(SimulationHost& host, Control control, ControlCaller caller = {}) {
  std::promise<ControlResult> promise;
  auto result = promise.get_future();
  host.Submit(
      std::move(control), [&](ControlResult r) { promise.set_value(std::move(r)); },
      std::move(caller));
  return result.get();
}

// Submits a control and returns its answer to come.
std::future<ControlResult> Submit(SimulationHost& host, Control control,
                                  ControlCaller caller = {}) {
  auto promise = std::make_shared<std::promise<ControlResult>>();
  auto result = promise->get_future();
  host.Submit(
      std::move(control), [promise](ControlResult r) { promise->set_value(std::move(r)); },
      std::move(caller));
  return result;
}

bool WaitForFrame(const SimulationHost& host, uint64_t frame) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (host.Status().frame < frame) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return true;
}

// Holds the simulation thread: submits a Resume whose answer blocks that thread until release().
class ThreadHolder {
 public:
  explicit ThreadHolder(SimulationHost& host) {
    auto held = std::make_shared<std::promise<void>>();
    auto is_held = held->get_future();
    host.Submit(ResumeControl{}, [held, released = release_.get_future().share()](ControlResult) {
      held->set_value();
      released.wait();
    });
    is_held.wait();
  }
  ~ThreadHolder() { release(); }
  void release() {
    if (!released_) release_.set_value();
    released_ = true;
  }

 private:
  std::promise<void> release_;
  bool released_ = false;
};

// A wcsph dam of 600 particles with 25 ms frames: over a hundred CFL-limited steps each, a few
// tenths of a second, so controls arrive in the middle of a frame.
Scene LongFrameScene() {
  Scene scene = ParseScene(R"({
    "domain": {"min": [0, 0, 0], "max": [0.6, 0.4, 0.08]},
    "fluid_blocks": [{"center": [0.1, 0.15, 0.04], "size": [0.2, 0.3, 0.08]}],
    "solver": "wcsph",
    "params": {"gravity": -9.81, "particle_spacing": 0.02, "speed_of_sound": 25,
               "frame_rate": 40}
  })");
  return scene;
}

class SimulationHostTest : public ::testing::Test {
 protected:
  void SetUp() override { host_.Start(); }
  SimulationHost host_{SmallScene(), Paused()};
};

TEST_F(SimulationHostTest, StepAndStepBackMoveByFramesAndPause) {
  ControlResult r = Apply(host_, StepControl{5});
  ASSERT_EQ(r.code, ControlCode::kOk) << r.message;
  EXPECT_EQ(r.frames_moved, 5u);
  EXPECT_EQ(r.status.frame, 5u);
  EXPECT_EQ(r.status.step, 5u * 3);
  EXPECT_FALSE(r.status.running);
  r = Apply(host_, StepBackControl{2});
  EXPECT_EQ(r.frames_moved, 2u);
  EXPECT_EQ(r.status.frame, 3u);
  r = Apply(host_, StepBackControl{100});  // stops at frame 0
  EXPECT_EQ(r.frames_moved, 3u);
  EXPECT_EQ(r.status.frame, 0u);
  EXPECT_EQ(r.status.time, 0.0);
}

TEST_F(SimulationHostTest, StepBackThenForwardReachesBitIdenticalStates) {
  std::vector<uint64_t> first;
  for (int f = 1; f <= 12; ++f) first.push_back(Apply(host_, StepControl{1}).status.state_hash);
  ASSERT_NE(first[3], first[11]);
  ControlResult r = Apply(host_, StepBackControl{8});
  EXPECT_EQ(r.status.frame, 4u);
  EXPECT_EQ(r.status.state_hash, first[3]);
  for (int f = 5; f <= 12; ++f) {
    r = Apply(host_, StepControl{1});
    ASSERT_EQ(r.status.state_hash, first[f - 1]) << "frame " << f;
  }
}

TEST_F(SimulationHostTest, StepCountsOutsideTheRangeAreRefused) {
  ControlResult r = Apply(host_, StepControl{0});
  EXPECT_EQ(r.code, ControlCode::kInvalidArgument);
  EXPECT_NE(r.message.find("count"), std::string::npos);
  r = Apply(host_, StepBackControl{kMaxStepCount + 1});
  EXPECT_EQ(r.code, ControlCode::kInvalidArgument);
  EXPECT_EQ(r.status.frame, 0u);
}

TEST_F(SimulationHostTest, ResumeRunsFramesAndPauseStopsThem) {
  ControlResult r = Apply(host_, ResumeControl{});
  EXPECT_TRUE(r.status.running);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (host_.Status().frame < 3 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  r = Apply(host_, PauseControl{});
  EXPECT_FALSE(r.status.running);
  EXPECT_GE(r.status.frame, 3u);
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_EQ(host_.Status().frame, r.status.frame);
  EXPECT_GT(r.status.history_frames, 0u);
  ASSERT_FALSE(r.status.passes.empty());
  EXPECT_GT(r.status.passes[0].calls, 0u);
}

TEST_F(SimulationHostTest, AnInvalidParameterAppliesNothing) {
  const Params before = host_.CurrentParams();
  ControlResult r = Apply(host_, UpdateParamsControl{{{"gravity", -5.0}, {"viscosity", -1.0}}});
  EXPECT_EQ(r.code, ControlCode::kInvalidArgument);
  EXPECT_NE(r.message.find("viscosity"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("[0, 10]"), std::string::npos) << r.message;
  EXPECT_EQ(host_.CurrentParams().gravity, before.gravity);
  r = Apply(host_, UpdateParamsControl{{{"no_such_thing", 1.0}}});
  EXPECT_EQ(r.code, ControlCode::kInvalidArgument);
  EXPECT_NE(r.message.find("no_such_thing"), std::string::npos) << r.message;
}

TEST_F(SimulationHostTest, ParametersApplyAndResetOnlyWhenTheyMust) {
  Apply(host_, StepControl{4});
  ControlResult r = Apply(host_, UpdateParamsControl{{{"gravity", -5.0}}});
  ASSERT_EQ(r.code, ControlCode::kOk) << r.message;
  EXPECT_FALSE(r.reset);
  EXPECT_EQ(r.params.gravity, -5.0);
  EXPECT_EQ(r.status.frame, 4u);
  r = Apply(host_, UpdateParamsControl{{{"particle_quantity", 8.0}}});
  ASSERT_EQ(r.code, ControlCode::kOk) << r.message;
  EXPECT_TRUE(r.reset);
  EXPECT_EQ(r.status.particles, 512u);
  EXPECT_EQ(r.status.frame, 0u);
}

TEST_F(SimulationHostTest, LoadSceneReplacesTheSceneAndResets) {
  Apply(host_, StepControl{2});
  Scene next = SmallScene(6);
  next.name = "six";
  ControlResult r = Apply(host_, LoadSceneControl{std::move(next)});
  ASSERT_EQ(r.code, ControlCode::kOk) << r.message;
  EXPECT_TRUE(r.reset);
  EXPECT_EQ(r.status.scene, "six");
  EXPECT_EQ(r.status.particles, 216u);
  EXPECT_EQ(r.status.frame, 0u);
}

TEST_F(SimulationHostTest, TheSceneDescriptionChangesWithTheSpawnOnly) {
  HostScene scene = host_.CurrentScene();
  EXPECT_EQ(scene.scene.name, "seed_basic");
  EXPECT_EQ(scene.scene.solver, "seed");
  EXPECT_EQ(scene.scene.domain.min, Vec3d(-5, -3, -5));
  EXPECT_EQ(scene.scene.domain.max, Vec3d(5, 3, 5));
  EXPECT_DOUBLE_EQ(scene.particle_radius, 0.5 * 1.2 / 9);  // 10 particles over 1.2 m
  const uint64_t version = scene.scene_version;
  EXPECT_GT(version, 0u);
  EXPECT_EQ(host_.Status().scene_version, version);
  // Pause, step, step back, a plain reset and a parameter that needs no reset keep it.
  Apply(host_, PauseControl{});
  Apply(host_, StepControl{2});
  Apply(host_, StepBackControl{1});
  Apply(host_, ResetControl{});
  ControlResult r = Apply(host_, UpdateParamsControl{{{"viscosity", 0.01}}});
  EXPECT_EQ(r.status.scene_version, version);
  EXPECT_EQ(host_.CurrentScene().scene_version, version);
  // A re-spawn with other parameters, and a new scene, change it.
  r = Apply(host_, UpdateParamsControl{{{"particle_quantity", 7.0}}});
  ASSERT_TRUE(r.reset);
  EXPECT_GT(r.status.scene_version, version);
  scene = host_.CurrentScene();
  EXPECT_EQ(scene.scene_version, r.status.scene_version);
  EXPECT_DOUBLE_EQ(scene.particle_radius, 0.5 * 1.2 / 6);
  r = Apply(host_, LoadSceneControl{LoadScene("seed_obstacles")});
  ASSERT_EQ(r.code, ControlCode::kOk) << r.message;
  EXPECT_GT(r.status.scene_version, scene.scene_version);
  scene = host_.CurrentScene();
  EXPECT_EQ(scene.scene.name, "seed_obstacles");
  ASSERT_EQ(scene.scene.spheres.size(), 1u);
  ASSERT_EQ(scene.scene.boxes.size(), 1u);
  EXPECT_DOUBLE_EQ(scene.scene.spheres[0].radius, 1.0);
  // 18 x 24 x 24 particles over 3 x 4 x 4 m: the closest are 4 / 23 m apart.
  EXPECT_DOUBLE_EQ(scene.particle_radius, 0.5 * 4.0 / 23);
}

TEST(SimulationHostLimitsTest, TheParticleLimitRefusesScenesAndParameters) {
  HostOptions options = Paused();
  options.max_particles = 1000;
  EXPECT_THROW(SimulationHost(SmallScene(11), options), ConfigError);
  SimulationHost host(SmallScene(10), options);
  host.Start();
  ControlResult r = Apply(host, UpdateParamsControl{{{"particle_quantity", 11.0}}});
  EXPECT_EQ(r.code, ControlCode::kResourceExhausted);
  EXPECT_NE(r.message.find("1331"), std::string::npos) << r.message;
  EXPECT_EQ(host.Status().particles, 1000u);
  r = Apply(host, LoadSceneControl{SmallScene(12)});
  EXPECT_EQ(r.code, ControlCode::kResourceExhausted);
  EXPECT_EQ(host.Status().particles, 1000u);
}

TEST_F(SimulationHostTest, TheStatusNamesTheDevice) {
  const HostStatus status = host_.Status();
  EXPECT_EQ(status.device, "cpu");  // HostOptions' default
  EXPECT_EQ(status.device_memory_bytes, 0u);
  const ControlResult r = Apply(host_, LoadSceneControl{SmallScene(8)});
  ASSERT_EQ(r.code, ControlCode::kOk) << r.message;
  EXPECT_EQ(r.status.device, "cpu");
}

// No machine has a 64th GPU (cuda:63, the largest ordinal ParseDevice takes), and this one may
// have none at all: the host refuses to start, naming the device field, whatever is missing.
TEST(SimulationHostDeviceTest, AnUnavailableDeviceIsAConfigErrorNamingTheDevice) {
  HostOptions options = Paused();
  options.device = ParseDevice("cuda:63");
  try {
    SimulationHost host(SmallScene(), options);
    ADD_FAILURE() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.field(), "device") << e.what();
    EXPECT_EQ(e.message(), DeviceUnavailableReason(options.device));
  }
}

// ---------------------------------------------------------------------------------------------
// Controls between steps, and callers that gave up.

// A pause inside a frame far longer than the landing budget does not wait for the frame: it
// rolls the frame back to its start (frame_stepper.h), and the frame stepped again from there
// reaches the state of one frame stepped whole.
TEST(SimulationHostStepsTest, APauseInsideALongFrameRollsItBackAndItIsSteppedAgainUnchanged) {
  HostOptions options = Paused();
  options.landing_budget = std::chrono::milliseconds(1);
  std::vector<std::string> lines;
  std::mutex mu;
  options.log = [&](const std::string& line) {
    std::lock_guard lock(mu);
    lines.push_back(line);
  };
  SimulationHost host(LongFrameScene(), options);
  host.Start();
  const uint64_t start_hash = host.Status().state_hash;
  ASSERT_EQ(Apply(host, ResumeControl{}).code, ControlCode::kOk);
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ControlResult r = Apply(host, PauseControl{});
  ASSERT_EQ(r.code, ControlCode::kOk) << r.message;
  // Before landing existed, the Pause left the state inside the frame (time > 0); before
  // controls acted between steps, it waited for the frame's hundreds of steps (frame 1).
  EXPECT_EQ(r.status.frame, 0u) << "the Pause waited for the end of the frame";
  EXPECT_EQ(r.status.time, 0.0) << "the Pause left the state inside the frame";
  EXPECT_EQ(r.status.step, 0u);
  EXPECT_EQ(r.status.state_hash, start_hash);
  {
    std::lock_guard lock(mu);
    EXPECT_THAT(lines, ::testing::Contains(::testing::HasSubstr("rolled back to its start")));
  }
  // The kept start is timed in the status, once per frame begun.
  const auto kept = std::find_if(r.status.passes.begin(), r.status.passes.end(),
                                 [](const PassStatus& p) { return p.name == "keep_frame_start"; });
  ASSERT_NE(kept, r.status.passes.end());
  EXPECT_GE(kept->calls, 1u);
  r = Apply(host, StepControl{1});
  ASSERT_EQ(r.code, ControlCode::kOk) << r.message;
  EXPECT_EQ(r.frames_moved, 1u);
  EXPECT_EQ(r.status.frame, 1u);
  Simulation whole(LongFrameScene());
  whole.StepFrame();
  EXPECT_EQ(r.status.time, whole.time());
  EXPECT_EQ(r.status.step, whole.step());
  EXPECT_EQ(r.status.state_hash, StateHash(whole.state()));
}

// A parameter change applied inside a running frame is replayed where it was made when stepping
// back and forward again. The pause that follows rolls the frame back, so the change holds from
// the frame's start; the checkpoint there (not one in the middle, which re-simulation could not
// resume, nor none: checkpoints are 16 frames apart here) tells re-simulation about it.
TEST(SimulationHostStepsTest, AParameterChangeInsideAFrameStepsBackExactly) {
  HostOptions options = Paused();
  options.history.max_bytes = 100'000;  // a handful of checkpoints of 600 particles
  options.landing_budget = std::chrono::milliseconds(1);
  SimulationHost host(LongFrameScene(), options);
  host.Start();
  ASSERT_EQ(Apply(host, ResumeControl{}).code, ControlCode::kOk);
  std::this_thread::sleep_for(std::chrono::milliseconds(2));
  ControlResult r = Apply(host, UpdateParamsControl{{{"gravity", -3.0}}});
  ASSERT_EQ(r.code, ControlCode::kOk) << r.message;
  ASSERT_FALSE(r.reset);
  ASSERT_GT(r.status.time - double(r.status.frame) * 0.025, 1e-9)
      << "the change did not land inside a frame";
  r = Apply(host, PauseControl{});
  const uint64_t frame = r.status.frame;
  EXPECT_NEAR(r.status.time, double(frame) * 0.025, 1e-9) << "the Pause did not land on a frame";
  EXPECT_EQ(r.params.gravity, -3.0);
  r = Apply(host, StepControl{1});
  ASSERT_EQ(r.status.frame, frame + 1);
  const uint64_t after_change = r.status.state_hash;
  r = Apply(host, StepControl{2});
  ASSERT_EQ(r.status.frame, frame + 3);
  r = Apply(host, StepBackControl{2});
  ASSERT_EQ(r.status.frame, frame + 1);
  EXPECT_EQ(r.status.state_hash, after_change);
  EXPECT_EQ(r.params.gravity, -3.0);
}

TEST(SimulationHostStepsTest, APauseEndsAStepInProgressWhichReportsTheFramesItMoved) {
  SimulationHost host(SmallScene(), Paused());
  host.Start();
  auto step = Submit(host, StepControl{kMaxStepCount});
  ASSERT_TRUE(WaitForFrame(host, 2));
  const ControlResult pause = Apply(host, PauseControl{});
  ASSERT_EQ(step.wait_for(std::chrono::seconds(0)), std::future_status::ready)
      << "the Step was not answered before the Pause";
  const ControlResult stepped = step.get();
  ASSERT_EQ(stepped.code, ControlCode::kOk) << stepped.message;
  EXPECT_GE(stepped.frames_moved, 2u);
  EXPECT_LT(stepped.frames_moved, kMaxStepCount);
  EXPECT_EQ(stepped.status.frame, stepped.frames_moved);
  EXPECT_EQ(pause.status.frame, stepped.frames_moved);  // nothing stepped after it
  EXPECT_FALSE(pause.status.running);
}

TEST(SimulationHostStepsTest, AParameterChangeDuringAStepIsAppliedAndTheStepGoesOn) {
  SimulationHost host(SmallScene(), Paused());
  host.Start();
  auto step = Submit(host, StepControl{40});
  ASSERT_TRUE(WaitForFrame(host, 1));
  const ControlResult set = Apply(host, UpdateParamsControl{{{"gravity", -2.0}}});
  ASSERT_EQ(set.code, ControlCode::kOk) << set.message;
  EXPECT_LT(set.status.frame, 40u);
  const ControlResult stepped = step.get();
  ASSERT_EQ(stepped.code, ControlCode::kOk) << stepped.message;
  EXPECT_EQ(stepped.frames_moved, 40u);
  EXPECT_EQ(stepped.params.gravity, -2.0);
}

TEST(SimulationHostStepsTest, AStepEndsBeforeItsCallersDeadlineOrWhenItsCallerCancels) {
  SimulationHost host(SmallScene(), Paused());
  host.Start();
  ControlCaller soon;
  soon.deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(400);
  ControlResult r = Apply(host, StepControl{kMaxStepCount}, soon);
  // Answered (applied, with what it did) while its caller still waits.
  ASSERT_EQ(r.code, ControlCode::kOk) << r.message;
  EXPECT_LE(std::chrono::steady_clock::now(), soon.deadline);
  EXPECT_LT(r.frames_moved, kMaxStepCount);
  EXPECT_EQ(r.status.frame, r.frames_moved);

  auto gone = std::make_shared<std::atomic<bool>>(false);
  ControlCaller cancelling;
  cancelling.cancelled = [gone] { return gone->load(); };
  auto step = Submit(host, StepControl{kMaxStepCount}, cancelling);
  ASSERT_TRUE(WaitForFrame(host, r.status.frame + 1));
  *gone = true;
  r = step.get();
  EXPECT_EQ(r.code, ControlCode::kCancelled);
  const uint64_t frame = host.Status().frame;
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_EQ(host.Status().frame, frame);  // it stopped stepping
  EXPECT_FALSE(host.Status().running);
}

TEST(SimulationHostCallerTest, AControlWhoseCallerGaveUpWhileQueuedIsNotApplied) {
  std::vector<std::string> log;
  std::mutex log_mu;
  HostOptions options = Paused();
  options.log = [&](const std::string& line) {
    std::lock_guard lock(log_mu);
    log.push_back(line);
  };
  SimulationHost host(SmallScene(), options);
  host.Start();
  std::future<ControlResult> late, cancelled, waiting;
  {
    ThreadHolder holder(host);  // a slow control: the thread is busy with it
    ControlCaller short_deadline;
    short_deadline.deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(50);
    late = Submit(host, PauseControl{}, short_deadline);
    ControlCaller gone;
    gone.cancelled = [] { return true; };
    cancelled = Submit(host, StepBackControl{1}, gone);
    ControlCaller patient;
    patient.deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    waiting = Submit(host, UpdateParamsControl{{{"gravity", -4.0}}}, patient);
    std::this_thread::sleep_for(std::chrono::milliseconds(150));  // past the short deadline
  }
  ControlResult r = late.get();
  EXPECT_EQ(r.code, ControlCode::kDeadlineExceeded);
  EXPECT_NE(r.message.find("not applied"), std::string::npos) << r.message;
  EXPECT_TRUE(r.status.running) << "the Pause was applied";
  r = cancelled.get();
  EXPECT_EQ(r.code, ControlCode::kCancelled);
  // The one whose caller still waits is applied, and says so.
  r = waiting.get();
  EXPECT_EQ(r.code, ControlCode::kOk) << r.message;
  EXPECT_EQ(r.params.gravity, -4.0);
  EXPECT_TRUE(host.Status().running);
  std::lock_guard lock(log_mu);
  EXPECT_THAT(log, ::testing::Contains(::testing::HasSubstr("Pause skipped, not applied")));
  EXPECT_THAT(log, ::testing::Contains(::testing::HasSubstr("StepBack skipped, not applied")));
}

TEST(SimulationHostLimitsTest, StopAnswersQueuedControlsWithoutWaitingForTheThread) {
  SimulationHost host(SmallScene(), Paused());
  host.Start();
  auto holder = std::make_unique<ThreadHolder>(host);
  auto queued = Submit(host, PauseControl{});
  host.RequestStop();  // the thread is busy: the queue is answered here
  ASSERT_EQ(queued.wait_for(std::chrono::seconds(0)), std::future_status::ready);
  EXPECT_EQ(queued.get().code, ControlCode::kUnavailable);
  EXPECT_FALSE(host.StopWithin(std::chrono::steady_clock::now() + std::chrono::milliseconds(20)));
  holder->release();
  EXPECT_TRUE(host.StopWithin(std::chrono::steady_clock::now() + std::chrono::seconds(60)));
  holder.reset();
}

TEST(SimulationHostLimitsTest, ControlsAfterStopAreAnsweredUnavailable) {
  SimulationHost host(SmallScene(), Paused());
  host.Start();
  host.Stop();
  EXPECT_EQ(Apply(host, StepControl{1}).code, ControlCode::kUnavailable);
}

// A subscriber joining a paused simulation still gets the current frame.
TEST_F(SimulationHostTest, ALateJoinerOfAPausedSimulationGetsAFrame) {
  Apply(host_, StepControl{3});
  struct Listener : FrameListener {
    void OnFrameReady() override {
      if (!called.exchange(true)) ready.set_value();
    }
    void OnHubClosed() override {}
    std::atomic<bool> called{false};
    std::promise<void> ready;
  } listener;
  SubscriptionOptions options;
  auto sub = host_.hub().Subscribe(options, &listener);
  ASSERT_EQ(listener.ready.get_future().wait_for(std::chrono::seconds(30)),
            std::future_status::ready);
  const auto frame = sub->Take(nullptr);
  ASSERT_TRUE(frame);
  EXPECT_TRUE(frame->keyframe);
  EXPECT_EQ(frame->frame, 3u);
  host_.hub().Unsubscribe(sub);
}

// The OpenMP thread count is per native thread: the option must reach the simulation thread,
// not only the thread that created the host (dysa-server --threads was once lost that way).
TEST(SimulationHostThreadsTest, TheSolverThreadCountReachesTheSimulationThread) {
  HostOptions options = Paused();
  options.solver_threads = 3;
  SimulationHost host(SmallScene(), options);
  host.Start();
  const ControlResult r = Apply(host, StepControl{1});
  ASSERT_EQ(r.code, ControlCode::kOk) << r.message;
  EXPECT_EQ(r.status.solver_threads, 3u);
}

// A scene built in code (or named after a file) may hold any text: each log line stays one
// line, bounded, whatever the scene's name holds.
TEST(SimulationHostLogTest, LogLinesEscapeControlCharactersAndStayBounded) {
  std::vector<std::string> lines;
  std::mutex mu;
  HostOptions options = Paused();
  options.log = [&](const std::string& line) {
    std::lock_guard lock(mu);
    lines.push_back(line);
  };
  Scene forged = SmallScene();
  forged.name = "a\n2026-01-01T00:00:00.000Z dysa-server: stopped\x1b[2J";
  SimulationHost host(std::move(forged), options);
  host.Start();
  Scene huge = SmallScene();
  huge.name = std::string(1'000'000, 'n');
  ASSERT_EQ(Apply(host, LoadSceneControl{std::move(huge)}).code, ControlCode::kOk);
  host.Stop();
  std::lock_guard lock(mu);
  ASSERT_GE(lines.size(), 2u);
  EXPECT_NE(lines[0].find("scene 'a\\n2026-01-01T00:00:00.000Z dysa-server: stopped\\x1b[2J'"),
            std::string::npos)
      << lines[0];
  for (const std::string& line : lines) {
    EXPECT_LE(line.size(), kMaxLogLineBytes);
    for (char c : line) EXPECT_FALSE(static_cast<unsigned char>(c) < 0x20) << line;
  }
  EXPECT_NE(lines.back().find("bytes)"), std::string::npos) << lines.back().substr(0, 200);
}

}  // namespace
}  // namespace dysa::service
