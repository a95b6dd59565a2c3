// The simulation thread of the server: runs frames at the chosen rate, applies controls between
// solver steps in the order they arrive, keeps the step-back history and publishes frames to the
// hub.
//
// Controls act between steps, not only between frames: a frame of a physical solver is many
// adaptive steps, and a scene can make each of them slow. A running frame is advanced in pieces
// (Simulation::StepFrame(interrupted)) and interrupted as soon as a control is queued; it goes on
// from where it stopped once the control is applied, unless the control moved the state
// elsewhere. A control whose caller has given up (its deadline passed, or it cancelled) before
// the thread got to it is answered kDeadlineExceeded or kCancelled and not applied.
//
// No RPC types here: the gRPC adapter (simulation_service.cc) converts its requests into
// Controls and ControlResults back into replies. Nothing a caller does waits for a step:
// Submit() queues and returns; Status(), CurrentParams() and CurrentScene() read copies refreshed
// by the simulation thread.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <variant>
#include <vector>

#include "dysa/core/device.h"
#include "dysa/core/history.h"
#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "dysa/service/frame_hub.h"
#include "dysa/service/frame_publisher.h"

namespace dysa::service {

struct HostOptions {
  double frame_rate = 60;  // frames per wall second the thread aims for; 0: as fast as possible
  HistoryConfig history;
  uint64_t max_particles =
      kMaxStreamedParticles;  // scenes and parameter sets beyond it are refused
  size_t max_subscribers = 64;
  bool start_paused = false;
  // OpenMP threads the solver steps with; 0: the creating thread's OpenMP default (every core
  // unless OMP_NUM_THREADS says otherwise). Frames are encoded on a thread of their own with the
  // cores left over, or on the simulation thread when none are (FramePublisher). On a GPU the
  // solver needs no cores: these threads only put frames in id order (gather_frames), and the
  // publishing thread has every core but one whatever this says.
  int solver_threads = 0;
  // Where every simulation of the host steps, including the scenes LoadScene brings: the CPU, or
  // a CUDA GPU (dysa-server --device). Scenes whose solver has no GPU backend are refused there.
  Device device;
  // One line per significant event (scene loaded, reset, alarm, ...), at most kMaxLogLineBytes
  // with control characters escaped (SafeText); may be empty.
  std::function<void(const std::string&)> log;
};

struct PassStatus {
  std::string name;
  double last_ms = 0;
  double mean_ms = 0;
  uint64_t calls = 0;
};

struct HostStatus {
  bool running = false;
  uint64_t step = 0;
  uint64_t frame = 0;
  double time = 0;  // s
  uint32_t particles = 0;
  std::string solver;
  std::string scene;
  double frames_per_second = 0;  // simulated frames per wall second, over the last second
  double target_frame_rate = 0;
  // The solver's passes, then, once anyone has subscribed, "gather_frames" (copying the
  // particles into a frame in id order, on the simulation thread) and "publish_frames"
  // (encoding it and starting the writes, on the publishing thread), per frame.
  std::vector<PassStatus> passes;
  uint32_t solver_threads = 0;  // OpenMP threads the simulation thread steps with
  // Simulation::DeviceDescription(): "cpu" or e.g. "cuda:0 NVIDIA H200, 139.8 GiB, sm_90".
  std::string device;
  uint64_t device_memory_bytes = 0;  // bytes of GPU memory the simulation holds; 0 on the CPU
  uint32_t subscribers = 0;
  std::string alarm;    // empty when healthy
  std::string warning;  // the solver's latest accuracy warning (Simulation::warning())
  uint64_t history_frames = 0;
  uint64_t history_bytes = 0;
  uint64_t frames_encoded = 0;
  uint64_t state_hash = 0;  // StateHash while paused (0 while running: not worth a frame's time)
  // Changes whenever CurrentScene() changes: a scene loaded, or a parameter change that
  // re-spawned the fluid. Starts at 1.
  uint64_t scene_version = 0;
};

// The running scene, as GetScene describes it.
struct HostScene {
  Scene scene;                 // as loaded, with the solver it runs
  double particle_radius = 0;  // m, SpawnParticleRadius with the current parameters
  uint64_t scene_version = 0;  // HostStatus::scene_version of this description
};

// Controls, applied between two solver steps.
struct PauseControl {};
struct ResumeControl {};
// Runs `count` frames, then pauses; answered when they are done, or earlier, with the frames it
// moved, when another control but a parameter change arrives (which is then applied), when the
// caller is about to stop waiting (kReplyMargin before its deadline) or has gone, or when the
// simulation diverges. A parameter change is applied between its steps and the Step goes on.
struct StepControl {
  uint32_t count = 1;  // frames
};
struct StepBackControl {
  uint32_t count = 1;  // frames
};
struct ResetControl {};
struct UpdateParamsControl {
  std::vector<std::pair<std::string, double>> values;  // name, value in the declared unit
};
struct LoadSceneControl {
  Scene scene;  // parsed and validated by the caller (ParseScene/LoadScene)
};
using Control = std::variant<PauseControl, ResumeControl, StepControl, StepBackControl,
                             ResetControl, UpdateParamsControl, LoadSceneControl>;

// "Pause", "Step", ...: for the log.
const char* ControlName(const Control& control);

enum class ControlCode {
  kOk,
  kInvalidArgument,
  kResourceExhausted,
  kFailedPrecondition,
  kUnavailable,
  kDeadlineExceeded,  // not applied: the caller's deadline passed (or left no time to answer)
  kCancelled          // not applied (or a Step ended): the caller cancelled the call
};

// The caller waiting for a control's answer, as the simulation thread sees it when it gets to
// the control.
struct ControlCaller {
  // When the caller stops waiting for the answer; max(): never.
  std::chrono::steady_clock::time_point deadline = std::chrono::steady_clock::time_point::max();
  // True once the caller has gone (it cancelled the call, or its connection broke); empty: never
  // goes. Called on the simulation thread, before the control is answered.
  std::function<bool()> cancelled;
};

// A control is applied only while at least this much is left before its caller's deadline, so
// that the answer of a control applied reaches the caller in time (a control that is applied is
// reported applied); with less left, it is answered kDeadlineExceeded and not applied. A Step
// ends this long before its caller's deadline, answered with the frames it moved.
inline constexpr std::chrono::milliseconds kReplyMargin{100};

struct ControlResult {
  ControlCode code = ControlCode::kOk;
  std::string message;  // for errors: names the field and its allowed range
  bool reset = false;   // the fluid was re-spawned
  uint32_t frames_moved = 0;
  HostStatus status;  // after the control
  Params params;      // after the control
};

// Fills `snapshot` from the simulation's current frame: positions, and velocities or densities
// when `fields` (codec fields) need them, scattered from storage order into id order.
void GatherSnapshot(const Simulation& sim, uint32_t fields, FrameSnapshot& snapshot);

// The longest line SimulationHost logs; a longer one is cut, stating its length.
inline constexpr size_t kMaxLogLineBytes = 4096;

// Frames one Step control may advance at most (the thread does nothing else meanwhile).
inline constexpr uint32_t kMaxStepCount = 10000;

class SimulationHost {
 public:
  // Throws ConfigError for an invalid scene or one over options.max_particles, and
  // ConfigError("device", ...) when options.device cannot run it (no GPU, or no GPU backend for
  // the scene's solver).
  SimulationHost(Scene scene, HostOptions options);
  ~SimulationHost();  // Stop()
  SimulationHost(const SimulationHost&) = delete;
  SimulationHost& operator=(const SimulationHost&) = delete;

  void Start();
  // Asks the thread to stop at its next step boundary, without waiting for it: queued controls
  // are answered kUnavailable at once (on the calling thread), a Step in progress by the
  // simulation thread as it stops, and later ones when submitted.
  void RequestStop();
  // RequestStop(), then waits until `deadline` for the thread to return. True: it returned and is
  // joined, and nothing is published any more. False: it is still inside a solver step (a step
  // cannot be interrupted); the host cannot be destroyed before the step ends (the destructor
  // waits for it), so a process that must end now exits without destroying it.
  bool StopWithin(std::chrono::steady_clock::time_point deadline);
  // StopWithin with no deadline.
  void Stop();

  FrameHub& hub() { return hub_; }
  HostStatus Status() const;
  Params CurrentParams() const;
  HostScene CurrentScene() const;
  const HostOptions& options() const { return options_; }

  // Queues a control; `done` runs once it is applied, refused or skipped (its caller gone): on
  // the simulation thread, or on RequestStop's caller for a control still queued then.
  void Submit(Control control, std::function<void(ControlResult)> done, ControlCaller caller = {});

 private:
  struct Job {
    Control control;
    std::function<void(ControlResult)> done;
    ControlCaller caller;
    std::chrono::steady_clock::time_point queued;
  };
  // A Step control being carried out between other controls.
  struct ActiveStep {
    Job job;
    uint32_t count = 0;
    uint32_t moved = 0;  // frames completed so far
  };

  void Loop();
  // Applies a dequeued control, or answers it unapplied when its caller is gone.
  void Handle(Job& job);
  // Validates a Step and makes it the active one (answered later, by FinishStep).
  void BeginStep(Job& job);
  // Advances the active Step by a frame, or part of one when something interrupts it.
  void ContinueStep();
  // Answers the active Step with `result` (frames_moved filled in) and ends it.
  void FinishStep(ControlResult result, const std::string& why);
  // Fills the result's status and parameters, then answers the job.
  void Answer(Job& job, ControlResult result);
  ControlResult Apply(Control& control);
  // Advances the running frame until it completes (true) or `interrupted()` stops it between two
  // steps (false; the next call goes on with the same frame). A completed frame is recorded and
  // published; a diverged one raises the alarm and pauses.
  bool AdvanceFrame(const std::function<bool()>& interrupted);
  // A scene or parameter set over the particle limit: the message, or "" when it fits.
  std::string CheckParticleLimit(const Scene& scene, const Params& params) const;
  void StartScene();
  // The scene or its spawn changed: describes it anew under a new scene_version.
  void DescribeScene();
  void Publish(bool force, bool discontinuity);
  void RefreshStatus();
  void Log(const std::string& line) const;

  const HostOptions options_;
  const int solver_threads_;
  FrameHub hub_;
  FramePublisher publisher_;

  // Simulation thread only.
  std::unique_ptr<Simulation> sim_;
  History history_;
  bool running_ = false;
  std::string alarm_;
  std::optional<ActiveStep> step_;
  // Parameters changed (without a reset) while a frame was partly stepped: the frame's end gets
  // the checkpoint that tells re-simulation of the change (History::RecordParameterChange), so
  // that stepping back and forward again repeats the frame with the change where it was made.
  bool params_changed_in_frame_ = false;
  FrameSnapshot snapshot_;  // reused buffers
  std::deque<std::chrono::steady_clock::time_point> recent_frames_;
  StageTiming gather_;  // gathering frames for subscribers
  // OpenMP threads of the simulation thread, as it reads them; the configured count until it
  // starts.
  int running_threads_ = solver_threads_;
  uint64_t scene_version_ = 0;

  std::mutex mu_;
  std::condition_variable wake_;
  std::deque<Job> queue_;
  bool stop_ = false;
  bool finished_ = false;  // Loop has returned
  std::condition_variable finished_cv_;
  // queue_ holds a control or stop_ is set: a running frame or a Step yields to it between two
  // steps. Written under mu_, read by the solver's step loop without it.
  std::atomic<bool> attention_{false};
  bool frame_needed_ = false;  // a subscriber waits for a frame (see FrameHub::set_frame_needed)

  mutable std::mutex status_mu_;
  HostStatus status_;
  Params params_;
  HostScene scene_;

  std::thread thread_;
};

}  // namespace dysa::service
