// The simulation thread: its lifecycle, its loop, and the frames it steps, records and
// publishes. What each control does is in host_controls.cc.
#include "dysa/service/simulation_host.h"

#include <omp.h>

#include <algorithm>
#include <chrono>

#include "control_queue.h"
#include "dysa/core/text.h"
#include "dysa/core/types.h"

namespace dysa::service {

using Clock = std::chrono::steady_clock;

namespace {

// OpenMP threads of the publishing thread (0: publish inline on the simulation thread). On the
// CPU, the cores the solver leaves: with none left, a publishing thread would only take the
// solver's cycles. On a GPU the solver leaves every core but the simulation thread's own (which
// waits for the GPU and gathers frames), so frames encode while the GPU steps the next one
// instead of adding their encoding to every frame's time.
int PublisherThreads(const HostOptions& options, int solver_threads) {
  const int cores = omp_get_num_procs();
  if (options.device.is_cuda()) return std::max(1, cores - 1);
  return std::max(0, cores - solver_threads);
}

std::string Milliseconds(Clock::duration d) {
  return std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(d).count()) + " ms";
}

}  // namespace

SimulationHost::SimulationHost(Scene scene, HostOptions options)
    : options_(std::move(options)),
      solver_threads_(options_.solver_threads > 0 ? options_.solver_threads
                                                  : omp_get_max_threads()),
      hub_(options_.max_subscribers, options_.max_frame_particles),
      publisher_(hub_, PublisherThreads(options_, solver_threads_)),
      queue_(std::make_unique<ControlQueue>()),
      history_(options_.history),
      stepper_(options_.landing_budget) {
  if (const std::string over = CheckParticleLimit(scene, scene.params); !over.empty()) {
    throw ConfigError("max_particles", over);
  }
  sim_ = MakeSimulation(std::move(scene));
  running_ = !options_.start_paused;
  DescribeScene();
  StartScene();
  // A late joiner (or a subscriber that lost a frame) needs a frame even while paused.
  hub_.set_frame_needed([this] { queue_->RequestFrame(); });
}

SimulationHost::~SimulationHost() { Stop(); }

void SimulationHost::Start() {
  if (thread_.joinable()) return;
  thread_ = std::thread([this] {
    Loop();
    queue_->MarkFinished();
  });
}

void SimulationHost::RequestStop() {
  for (QueuedControl& job : queue_->Close()) {
    job.done(ControlError(ControlCode::kUnavailable, "the server is shutting down"));
  }
}

bool SimulationHost::StopWithin(Clock::time_point deadline) {
  RequestStop();
  if (thread_.joinable()) {
    if (!queue_->WaitFinished(deadline)) return false;
    thread_.join();
  }
  publisher_.Stop();
  return true;
}

void SimulationHost::Stop() { StopWithin(Clock::time_point::max()); }

HostStatus SimulationHost::Status() const {
  HostStatus status;
  {
    std::lock_guard lock(status_mu_);
    status = status_;
  }
  status.subscribers = uint32_t(hub_.subscribers());
  status.frames_encoded = hub_.frames_encoded();
  status.streams = hub_.StreamReports(SteadySeconds());
  return status;
}

Params SimulationHost::CurrentParams() const {
  std::lock_guard lock(status_mu_);
  return params_;
}

HostScene SimulationHost::CurrentScene() const {
  std::lock_guard lock(status_mu_);
  return scene_;
}

void SimulationHost::Submit(Control control, std::function<void(ControlResult)> done,
                            ControlCaller caller) {
  QueuedControl job{std::move(control), std::move(done), std::move(caller), Clock::now()};
  if (!queue_->Push(job)) {
    job.done(ControlError(ControlCode::kUnavailable, "the server is shutting down"));
  }
}

void SimulationHost::Loop() {
  // The OpenMP thread count is per native thread: this one's is set here.
  omp_set_num_threads(solver_threads_);
  running_threads_ = omp_get_max_threads();
  RefreshStatus();
  const auto yield_to_controls = [this] { return queue_->attention(); };
  auto next_frame = Clock::now();
  while (true) {
    // A Step, or a running frame that a control interrupted, goes on without waiting; paused,
    // the thread sleeps until something arrives; running, until the next frame is due.
    const bool busy = step_ || (running_ && sim_->frame_in_progress());
    Clock::time_point until = Clock::time_point::min();
    if (!busy && !running_) {
      until = Clock::time_point::max();
    } else if (!busy && options_.frame_rate > 0) {
      until = next_frame;
    }
    ControlQueue::Wake wake = queue_->Next(until);
    if (wake.stop) break;
    if (wake.control) {
      Handle(*wake.control);
      continue;
    }
    // While running or stepping, the next frame serves whoever waits for one.
    if (wake.frame_requested && !running_ && !step_) {
      Publish(/*force=*/true, /*discontinuity=*/false);
    }

    if (step_) {
      ContinueStep();
    } else if (running_ && (sim_->frame_in_progress() || Clock::now() >= next_frame)) {
      if (AdvanceFrame(yield_to_controls) && options_.frame_rate > 0) {
        const auto period = std::chrono::duration_cast<Clock::duration>(
            std::chrono::duration<double>(1.0 / options_.frame_rate));
        // Catch up after a short hiccup, but never burst after a long one (a slow frame).
        next_frame = std::max(next_frame + period, Clock::now() - period);
      }
    }
  }
  if (step_) {
    FinishStep(ControlError(ControlCode::kUnavailable, "the server is shutting down"), "shutdown");
  }
}

void SimulationHost::Handle(QueuedControl& job) {
  const Clock::time_point now = Clock::now();
  if (const ControlCode gone = CallerGone(job.caller, now); gone != ControlCode::kOk) {
    const std::string why =
        (gone == ControlCode::kCancelled ? std::string("its caller had cancelled the call")
                                         : "less than " + Milliseconds(kReplyMargin) +
                                               " was left before its caller's deadline") +
        " when the server got to it (queued " + Milliseconds(now - job.queued) + ")";
    Log(std::string(ControlName(job.control)) + " skipped, not applied: " + why);
    Answer(job, ControlError(gone, "not applied: " + why));
    return;
  }
  // Any control but a parameter change ends a Step in progress; the Step is answered first.
  if (step_ && !std::holds_alternative<UpdateParamsControl>(job.control)) {
    FinishStep(ControlResult{}, std::string(ControlName(job.control)) + " arrived");
  }
  if (std::holds_alternative<StepControl>(job.control)) {
    BeginStep(job);
    return;
  }
  ControlResult result = Apply(job.control);
  Answer(job, std::move(result));
}

void SimulationHost::Answer(QueuedControl& job, ControlResult result) {
  RefreshStatus();
  result.status = Status();
  result.params = sim_->params();
  job.done(std::move(result));
}

bool SimulationHost::AdvanceFrame(const std::function<bool()>& interrupted) {
  const uint64_t keeps = stepper_.keeps();
  const bool complete = stepper_.Advance(*sim_, interrupted);
  if (stepper_.keeps() != keeps) keep_start_.Add(stepper_.last_keep_ms());
  if (!sim_->alarm().empty()) {
    // The core stopped at the first step that diverged.
    alarm_ = sim_->alarm() + " (frame " + std::to_string(sim_->frame()) +
             "); paused. Step back, reset, or lower the time step";
    running_ = false;
    Log("alarm: " + alarm_);
    RefreshStatus();
    return false;  // never recorded, never streamed
  }
  if (!complete) return false;
  const auto record_start = Clock::now();
  if (params_changed_in_frame_) {
    history_.RecordParameterChange(*sim_);
    params_changed_in_frame_ = false;
  } else {
    history_.Record(*sim_);
  }
  record_.Add(std::chrono::duration<double, std::milli>(Clock::now() - record_start).count());
  recent_frames_.push_back(Clock::now());
  while (recent_frames_.front() < recent_frames_.back() - std::chrono::seconds(1)) {
    recent_frames_.pop_front();
  }
  Publish(/*force=*/!running_, /*discontinuity=*/false);
  RefreshStatus();
  return true;
}

void SimulationHost::LandOnFrame() {
  if (!sim_->frame_in_progress() || !alarm_.empty()) return;
  const Clock::time_point start = Clock::now();
  const Clock::time_point deadline = start + options_.landing_budget;
  const uint64_t frame = sim_->frame();
  const uint64_t step = sim_->step();
  if (stepper_.ExpectFinishedBy(*sim_, deadline)) {
    // Gives up between two steps when the next would end past the deadline (the steps turned
    // out slower than expected) and the frame's start is there to go back to.
    AdvanceFrame(
        [&] { return stepper_.CanRollBack(*sim_) && !stepper_.ExpectStepEndsBy(deadline); });
    if (!sim_->frame_in_progress()) {
      if (alarm_.empty()) {
        Log("stopped inside frame " + std::to_string(frame + 1) + " (step " + std::to_string(step) +
            "): finished it in " + Milliseconds(Clock::now() - start) + ", at step " +
            std::to_string(sim_->step()));
      }
      return;
    }
  }
  stepper_.RollBack(*sim_);
  if (params_changed_in_frame_) {
    history_.RecordParameterChange(*sim_);
    params_changed_in_frame_ = false;
  }
  Log("stopped inside frame " + std::to_string(frame + 1) + " (step " + std::to_string(step) +
      "): rolled back to its start, step " + std::to_string(sim_->step()) + ", in " +
      Milliseconds(Clock::now() - start));
  // Subscribers may not have been sent this frame (a running stream skips frames).
  Publish(/*force=*/true, /*discontinuity=*/false);
  RefreshStatus();
}

std::string SimulationHost::CheckParticleLimit(const Scene& scene, const Params& params) const {
  uint64_t total = 0;
  for (const auto& n : BlockParticleCounts(scene, params)) {
    total += uint64_t(n.x()) * uint64_t(n.y()) * uint64_t(n.z());
  }
  if (total <= options_.max_particles) return "";
  return "the scene would have " + std::to_string(total) +
         " particles; this server allows at most " + std::to_string(options_.max_particles) +
         " (dysa-server --max-particles)";
}

std::unique_ptr<Simulation> SimulationHost::MakeSimulation(Scene scene) const {
  if (options_.backend) {
    return std::make_unique<Simulation>(std::move(scene), options_.device, options_.backend);
  }
  return std::make_unique<Simulation>(std::move(scene), options_.device);
}

void SimulationHost::StartScene() {
  alarm_.clear();
  params_changed_in_frame_ = false;
  history_.Start(*sim_);
  stepper_.Forget();
  recent_frames_.clear();
  gather_ = {};
  record_ = {};
  keep_start_ = {};
  publisher_.ResetTiming();
  const Scene& scene = sim_->scene();
  Log("scene '" + scene.name + "': " + std::to_string(sim_->particle_count()) +
      " particles, solver " + scene.solver + " on " + sim_->DeviceDescription() + ", history " +
      std::to_string(history_.window()) + " frames (a checkpoint every " +
      std::to_string(history_.interval()) + ")");
  Publish(/*force=*/true, /*discontinuity=*/true);
  RefreshStatus();
}

void SimulationHost::DescribeScene() {
  HostScene d;
  d.scene = sim_->scene();
  d.particle_radius = SpawnParticleRadius(d.scene, sim_->params());
  d.scene_version = ++scene_version_;
  std::lock_guard lock(status_mu_);
  scene_ = std::move(d);
}

void SimulationHost::Publish(bool force, bool discontinuity) {
  const auto start = Clock::now();
  // Nothing is read or encoded when no one watches or, running, when every stream's frame-rate
  // cap would skip the frame.
  if (!GatherSnapshot(*sim_, hub_, /*any_time=*/force, discontinuity, snapshot_)) return;
  gather_.Add(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
  publisher_.Offer(snapshot_, force, discontinuity);
}

void SimulationHost::RefreshStatus() {
  HostStatus s;
  s.running = running_;
  // Paused, the state is a frame (LandOnFrame) and worth a hash; stepping, it changes per frame.
  DescribeSimulation(*sim_, /*hash=*/!running_ && !step_, s);
  if (recent_frames_.size() >= 2 && running_) {
    const double span =
        std::chrono::duration<double>(recent_frames_.back() - recent_frames_.front()).count();
    if (span > 0) s.frames_per_second = double(recent_frames_.size() - 1) / span;
  }
  s.target_frame_rate = options_.frame_rate;
  const auto add_stage = [&](const char* name, const StageTiming& t) {
    if (t.calls > 0) s.passes.push_back(PassStatus{name, t.last_ms, t.mean_ms, t.calls});
  };
  add_stage("keep_frame_start", keep_start_);
  add_stage("record_history", record_);
  add_stage("gather_frames", gather_);
  add_stage("publish_frames", publisher_.timing());
  s.solver_threads = uint32_t(running_threads_);
  s.alarm = alarm_;
  s.history_frames = history_.available(s.frame);
  s.history_bytes = history_.bytes();
  s.scene_version = scene_version_;
  std::lock_guard lock(status_mu_);
  status_ = std::move(s);
  params_ = sim_->params();
}

void SimulationHost::Log(const std::string& line) const {
  // Lines quote client text (scene names): one line each, whatever the text holds.
  if (options_.log) options_.log(SafeText(line, kMaxLogLineBytes));
}

}  // namespace dysa::service
