// The simulation thread of the server: runs frames at the chosen rate, applies controls between
// solver steps in the order they arrive, keeps the step-back history and publishes frames to the
// hub.
//
// Controls act between steps, not only between frames: a frame of a physical solver is many
// adaptive steps, and a scene can make each of them slow. A running frame is advanced in pieces
// (FrameStepper) and interrupted as soon as a control is queued; it goes on from where it stopped
// once the control is applied, unless the control moved the state elsewhere. Wherever the
// simulation stops (a Pause, the end of a Step), the frame in progress lands on a frame boundary,
// finished or rolled back (frame_stepper.h says which, and why): paused, the state is always a
// frame. A control whose caller has given up (its deadline passed, or it cancelled) before the
// thread got to it is answered kDeadlineExceeded or kCancelled and not applied.
//
// Where each part lives: the controls' types in controls.h, the queue that wakes the thread in
// src/control_queue.h, the thread's loop and its frames in simulation_host.cc, what each control
// does in host_controls.cc, the status in host_status.cc. No RPC types here: the gRPC adapter
// (simulation_service.cc) converts its requests into Controls and ControlResults back into
// replies. Nothing a caller does waits for a step: Submit() queues and returns; Status(),
// CurrentParams() and CurrentScene() read copies refreshed by the simulation thread.
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "dysa/core/device.h"
#include "dysa/core/history.h"
#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "dysa/service/controls.h"
#include "dysa/service/frame_hub.h"
#include "dysa/service/frame_publisher.h"
#include "dysa/service/frame_stepper.h"
#include "dysa/service/host_status.h"

namespace dysa::service {

class ControlQueue;
struct QueuedControl;

struct HostOptions {
  double frame_rate = 60;  // frames per wall second the thread aims for; 0: as fast as possible
  HistoryConfig history;
  // Scenes and parameter sets beyond it are refused. Up to kMaxParticles; above
  // max_frame_particles only budgeted streams can watch.
  uint64_t max_particles = kMaxStreamedParticles;
  // The most particles one frame holds (kMaxFrameParticles, the codec's limit; lower in tests).
  uint64_t max_frame_particles = kMaxFrameParticles;
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
  // Where every simulation of the host steps instead, when set: the backend this makes for
  // each scene (dysa-server under mpirun: the ranks, ranks_backend.h). Its ConfigErrors refuse
  // a scene or parameters as the device's do.
  Simulation::BackendFactory backend;
  // How long a frame interrupted by a pause may take to land on a frame boundary, beyond the
  // step in flight: it is finished when its remaining steps fit, otherwise rolled back to its
  // start (frame_stepper.h).
  std::chrono::milliseconds landing_budget{100};
  // One line per significant event (scene loaded, reset, alarm, a pause that landed inside a
  // frame, ...), at most kMaxLogLineBytes with control characters escaped (SafeText); may be
  // empty.
  std::function<void(const std::string&)> log;
};

// The longest line SimulationHost logs; a longer one is cut, stating its length.
inline constexpr size_t kMaxLogLineBytes = 4096;

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
  // A Step control being carried out between other controls.
  struct ActiveStep {
    std::unique_ptr<QueuedControl> job;
    uint32_t count = 0;
    uint32_t moved = 0;  // frames completed so far
  };

  void Loop();
  // Applies a dequeued control, or answers it unapplied when its caller is gone.
  void Handle(QueuedControl& job);
  // Validates a Step and makes it the active one (answered later, by FinishStep).
  void BeginStep(QueuedControl& job);
  // Advances the active Step by a frame, or part of one when something interrupts it.
  void ContinueStep();
  // Lands on a frame, then answers the active Step with `result` (frames_moved filled in) and
  // ends it.
  void FinishStep(ControlResult result, const std::string& why);
  // Fills the result's status and parameters, then answers the job.
  void Answer(QueuedControl& job, ControlResult result);
  ControlResult Apply(Control& control);
  // Advances the running frame until it completes (true) or `interrupted()` stops it between two
  // steps (false; the next call goes on with the same frame). A completed frame is recorded and
  // published; a diverged one raises the alarm and pauses.
  bool AdvanceFrame(const std::function<bool()>& interrupted);
  // Puts a frame in progress on a frame boundary, finished or rolled back (frame_stepper.h),
  // within options_.landing_budget; the frame it lands on is published.
  void LandOnFrame();
  // A scene or parameter set over the particle limit: the message, or "" when it fits.
  std::string CheckParticleLimit(const Scene& scene, const Params& params) const;
  void StartScene();
  // A simulation of `scene` on options_.device, or on options_.backend when set.
  std::unique_ptr<Simulation> MakeSimulation(Scene scene) const;
  // The scene or its spawn changed: describes it anew under a new scene_version.
  void DescribeScene();
  void Publish(bool force, bool discontinuity);
  void RefreshStatus();
  void Log(const std::string& line) const;

  const HostOptions options_;
  const int solver_threads_;
  FrameHub hub_;
  FramePublisher publisher_;
  std::unique_ptr<ControlQueue> queue_;

  // Simulation thread only.
  std::unique_ptr<Simulation> sim_;
  History history_;
  FrameStepper stepper_;
  bool running_ = false;
  std::string alarm_;
  std::optional<ActiveStep> step_;
  // Parameters changed (without a reset) while a frame was partly stepped: the frame's end (or
  // its start, when it is rolled back) gets the checkpoint that tells re-simulation of the
  // change (History::RecordParameterChange), so that stepping back and forward again repeats
  // the frame with the change where it was made.
  bool params_changed_in_frame_ = false;
  FrameSnapshot snapshot_;  // reused buffers
  std::deque<std::chrono::steady_clock::time_point> recent_frames_;
  StageTiming gather_;      // gathering frames for subscribers
  StageTiming record_;      // History::Record at each frame's end (a checkpoint every interval)
  StageTiming keep_start_;  // FrameStepper's checkpoint of a long frame's start
  // OpenMP threads of the simulation thread, as it reads them; the configured count until it
  // starts.
  int running_threads_ = solver_threads_;
  uint64_t scene_version_ = 0;

  mutable std::mutex status_mu_;
  HostStatus status_;
  Params params_;
  HostScene scene_;

  std::thread thread_;
};

}  // namespace dysa::service
