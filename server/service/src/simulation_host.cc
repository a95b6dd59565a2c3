#include "dysa/service/simulation_host.h"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

#include "dysa/core/text.h"
#include "dysa/core/types.h"

namespace dysa::service {

using Clock = std::chrono::steady_clock;

namespace {

template <class... Ts>
struct Overloaded : Ts... {
  using Ts::operator()...;
};
// C++20 deduces this for aggregates, but Clang only from version 17, and the fuzz build
// (scripts/fuzz.sh) uses Debian 12's Clang 14.
template <class... Ts>
Overloaded(Ts...) -> Overloaded<Ts...>;

ControlResult Error(ControlCode code, std::string message) {
  ControlResult result;
  result.code = code;
  result.message = std::move(message);
  return result;
}

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

// Why `caller` no longer waits for an answer at `now` (kOk while it does): a control is applied
// only with kReplyMargin left for its answer to arrive.
ControlCode CallerGone(const ControlCaller& caller, Clock::time_point now) {
  if (caller.cancelled && caller.cancelled()) return ControlCode::kCancelled;
  if (caller.deadline != Clock::time_point::max() && now + kReplyMargin > caller.deadline) {
    return ControlCode::kDeadlineExceeded;
  }
  return ControlCode::kOk;
}

std::string Milliseconds(Clock::duration d) {
  return std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(d).count()) + " ms";
}

int64_t UnixMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace

const char* ControlName(const Control& control) {
  return std::visit(Overloaded{
                        [](const PauseControl&) { return "Pause"; },
                        [](const ResumeControl&) { return "Resume"; },
                        [](const StepControl&) { return "Step"; },
                        [](const StepBackControl&) { return "StepBack"; },
                        [](const ResetControl&) { return "Reset"; },
                        [](const UpdateParamsControl&) { return "UpdateParams"; },
                        [](const LoadSceneControl&) { return "LoadScene"; },
                    },
                    control);
}

SimulationHost::SimulationHost(Scene scene, HostOptions options)
    : options_(std::move(options)),
      solver_threads_(options_.solver_threads > 0 ? options_.solver_threads
                                                  : omp_get_max_threads()),
      hub_(options_.max_subscribers),
      publisher_(hub_, PublisherThreads(options_, solver_threads_)),
      history_(options_.history) {
  if (const std::string over = CheckParticleLimit(scene, scene.params); !over.empty()) {
    throw ConfigError("max_particles", over);
  }
  sim_ = std::make_unique<Simulation>(std::move(scene), options_.device);
  running_ = !options_.start_paused;
  DescribeScene();
  StartScene();
  // A late joiner (or a subscriber that lost a frame) needs a frame even while paused.
  hub_.set_frame_needed([this] {
    std::lock_guard lock(mu_);
    frame_needed_ = true;
    wake_.notify_one();
  });
}

SimulationHost::~SimulationHost() { Stop(); }

void SimulationHost::Start() {
  if (thread_.joinable()) return;
  thread_ = std::thread([this] {
    Loop();
    std::lock_guard lock(mu_);
    finished_ = true;
    finished_cv_.notify_all();
  });
}

void SimulationHost::RequestStop() {
  std::deque<Job> left;
  {
    std::lock_guard lock(mu_);
    stop_ = true;
    attention_ = true;
    left.swap(queue_);
  }
  wake_.notify_one();
  for (Job& job : left) {
    job.done(Error(ControlCode::kUnavailable, "the server is shutting down"));
  }
}

bool SimulationHost::StopWithin(Clock::time_point deadline) {
  RequestStop();
  if (thread_.joinable()) {
    std::unique_lock lock(mu_);
    if (!finished_cv_.wait_until(lock, deadline, [&] { return finished_; })) return false;
    lock.unlock();
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
  {
    std::lock_guard lock(mu_);
    if (!stop_) {
      queue_.push_back(Job{std::move(control), std::move(done), std::move(caller), Clock::now()});
      attention_ = true;
      wake_.notify_one();
      return;
    }
  }
  done(Error(ControlCode::kUnavailable, "the server is shutting down"));
}

void SimulationHost::Loop() {
  // The OpenMP thread count is per native thread: this one's is set here.
  omp_set_num_threads(solver_threads_);
  running_threads_ = omp_get_max_threads();
  RefreshStatus();
  const auto yield_to_controls = [this] { return attention_.load(std::memory_order_relaxed); };
  auto next_frame = Clock::now();
  while (true) {
    std::optional<Job> job;
    bool frame_needed = false;
    {
      std::unique_lock lock(mu_);
      // A Step, or a running frame that a control interrupted, goes on without waiting.
      const bool busy = step_ || (running_ && sim_->frame_in_progress());
      auto ready = [&] { return stop_ || !queue_.empty() || frame_needed_; };
      if (!busy && !running_) {
        wake_.wait(lock, ready);
      } else if (!busy && options_.frame_rate > 0) {
        wake_.wait_until(lock, next_frame, ready);
      }
      if (stop_) break;
      // One control at a time: what is still queued interrupts whatever this one starts.
      if (!queue_.empty()) {
        job = std::move(queue_.front());
        queue_.pop_front();
        attention_ = !queue_.empty();
      } else {
        std::swap(frame_needed, frame_needed_);
      }
    }
    if (job) {
      Handle(*job);
      continue;
    }
    // While running or stepping, the next frame serves whoever waits for one.
    if (frame_needed && !running_ && !step_) Publish(/*force=*/true, /*discontinuity=*/false);

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
    FinishStep(Error(ControlCode::kUnavailable, "the server is shutting down"), "shutdown");
  }
}

void SimulationHost::Handle(Job& job) {
  const Clock::time_point now = Clock::now();
  if (const ControlCode gone = CallerGone(job.caller, now); gone != ControlCode::kOk) {
    const std::string why =
        (gone == ControlCode::kCancelled ? std::string("its caller had cancelled the call")
                                         : "less than " + Milliseconds(kReplyMargin) +
                                               " was left before its caller's deadline") +
        " when the server got to it (queued " + Milliseconds(now - job.queued) + ")";
    Log(std::string(ControlName(job.control)) + " skipped, not applied: " + why);
    Answer(job, Error(gone, "not applied: " + why));
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

void SimulationHost::Answer(Job& job, ControlResult result) {
  RefreshStatus();
  result.status = Status();
  result.params = sim_->params();
  job.done(std::move(result));
}

void SimulationHost::BeginStep(Job& job) {
  const StepControl& c = std::get<StepControl>(job.control);
  if (c.count < 1 || c.count > kMaxStepCount) {
    Answer(job, Error(ControlCode::kInvalidArgument,
                      "count: allowed range [1, " + std::to_string(kMaxStepCount) + "] frames"));
    return;
  }
  if (!alarm_.empty()) {
    Answer(job, Error(ControlCode::kFailedPrecondition,
                      "cannot step: " + alarm_ + " (StepBack or Reset first)"));
    return;
  }
  if (running_) Log("paused at frame " + std::to_string(sim_->frame()) + " to step");
  running_ = false;
  step_ = ActiveStep{std::move(job), c.count, 0};
  RefreshStatus();
}

void SimulationHost::ContinueStep() {
  ActiveStep& step = *step_;
  const ControlCode gone = CallerGone(step.job.caller, Clock::now());
  if (gone == ControlCode::kCancelled) {
    FinishStep(Error(gone, "cancelled by its caller"), "its caller cancelled it");
    return;
  }
  if (gone == ControlCode::kDeadlineExceeded) {
    // Answered while the caller still waits: the frames moved are reported.
    FinishStep(ControlResult{}, "its caller's deadline is near");
    return;
  }
  const bool complete = AdvanceFrame([&] {
    return attention_.load(std::memory_order_relaxed) ||
           CallerGone(step.job.caller, Clock::now()) != ControlCode::kOk;
  });
  if (complete && alarm_.empty()) ++step.moved;
  if (!alarm_.empty()) {
    FinishStep(ControlResult{}, "the simulation diverged");
  } else if (step.moved == step.count) {
    FinishStep(ControlResult{}, "");
  }
}

void SimulationHost::FinishStep(ControlResult result, const std::string& why) {
  ActiveStep step = std::move(*step_);
  step_.reset();
  if (!why.empty()) {
    Log("Step of " + std::to_string(step.count) + " frames ended after " +
        std::to_string(step.moved) + ": " + why);
  }
  result.frames_moved = step.moved;
  Answer(step.job, std::move(result));
}

bool SimulationHost::AdvanceFrame(const std::function<bool()>& interrupted) {
  const bool complete = sim_->StepFrame(interrupted);
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
  if (params_changed_in_frame_) {
    history_.RecordParameterChange(*sim_);
    params_changed_in_frame_ = false;
  } else {
    history_.Record(*sim_);
  }
  recent_frames_.push_back(Clock::now());
  while (recent_frames_.front() < recent_frames_.back() - std::chrono::seconds(1)) {
    recent_frames_.pop_front();
  }
  Publish(/*force=*/!running_, /*discontinuity=*/false);
  RefreshStatus();
  return true;
}

ControlResult SimulationHost::Apply(Control& control) {
  ControlResult result = std::visit(
      Overloaded{
          [&](PauseControl&) {
            if (running_) Log("paused at frame " + std::to_string(sim_->frame()));
            running_ = false;
            return ControlResult{};
          },
          [&](ResumeControl&) {
            if (!alarm_.empty()) {
              return Error(ControlCode::kFailedPrecondition,
                           "cannot resume: " + alarm_ + " (StepBack or Reset first)");
            }
            if (!running_) Log("resumed at frame " + std::to_string(sim_->frame()));
            running_ = true;
            return ControlResult{};
          },
          [&](StepControl&) {
            // Never reached: Handle hands Steps to BeginStep, which answers them later.
            return Error(ControlCode::kFailedPrecondition, "Step is not applied at once");
          },
          [&](StepBackControl& c) {
            if (c.count < 1 || c.count > kMaxStepCount) {
              return Error(
                  ControlCode::kInvalidArgument,
                  "count: allowed range [1, " + std::to_string(kMaxStepCount) + "] frames");
            }
            running_ = false;
            // A diverged state is not in the history: the last good frame is the one before.
            const uint64_t from = sim_->frame();
            const uint64_t target = from > c.count ? from - c.count : 0;
            // A frame in progress, and a parameter change within it, go with the rest.
            const uint64_t reached = history_.Restore(*sim_, target);
            params_changed_in_frame_ = false;
            alarm_.clear();
            ControlResult r;
            r.frames_moved = uint32_t(from - reached);
            Publish(/*force=*/true, /*discontinuity=*/true);
            return r;
          },
          [&](ResetControl&) {
            sim_->Reset();
            StartScene();
            Log("reset");
            ControlResult r;
            r.reset = true;
            return r;
          },
          [&](UpdateParamsControl& c) {
            Params next = sim_->params();
            try {
              for (const auto& [name, value] : c.values) SetParam(next, name, value);
              if (const std::string over = CheckParticleLimit(sim_->scene(), next); !over.empty()) {
                return Error(ControlCode::kResourceExhausted, over);
              }
              ControlResult r;
              r.reset = sim_->SetParams(next);
              std::ostringstream changed;
              for (const auto& [name, value] : c.values) changed << " " << name << "=" << value;
              Log("parameters changed:" + changed.str() + (r.reset ? " (reset)" : ""));
              if (r.reset) {
                DescribeScene();
                StartScene();
              } else if (sim_->frame_in_progress()) {
                params_changed_in_frame_ = true;  // recorded at the frame's end
              } else {
                history_.RecordParameterChange(*sim_);
              }
              return r;
            } catch (const ConfigError& e) {
              return Error(ControlCode::kInvalidArgument, e.what());
            }
          },
          [&](LoadSceneControl& c) {
            if (const std::string over = CheckParticleLimit(c.scene, c.scene.params);
                !over.empty()) {
              return Error(ControlCode::kResourceExhausted, over);
            }
            try {
              // On a GPU, a solver without a GPU backend fails here (ConfigError "device"):
              // the old scene runs on.
              auto next = std::make_unique<Simulation>(std::move(c.scene), options_.device);
              sim_ = std::move(next);
            } catch (const ConfigError& e) {
              return Error(ControlCode::kInvalidArgument, e.what());
            }
            DescribeScene();
            StartScene();
            ControlResult r;
            r.reset = true;
            return r;
          },
      },
      control);
  return result;
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

void SimulationHost::StartScene() {
  alarm_.clear();
  params_changed_in_frame_ = false;
  history_.Start(*sim_);
  recent_frames_.clear();
  gather_ = {};
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

void GatherSnapshot(const Simulation& sim, uint32_t fields, FrameSnapshot& s) {
  const size_t n = sim.particle_count();
  s.frame = sim.frame();
  s.step = sim.step();
  s.time = sim.time();
  const Aabb& domain = sim.model().domain;
  for (int a = 0; a < 3; ++a) {
    s.domain_min[a] = domain.min[a];
    s.domain_max[a] = domain.max[a];
  }
  s.produced_unix_us = UnixMicros();
  // Storage order is cell order and changes every step; subscribers index by id. On a GPU only
  // the fields asked for cross to the host, already in id order.
  const bool velocities = fields & (codec::kSpeed | codec::kVelocity);
  const bool densities = fields & codec::kDensity;
  s.positions.resize(3 * n);
  s.velocities.resize(velocities ? 3 * n : 0);
  s.densities.resize(densities ? n : 0);
  sim.ReadParticlesById({s.positions, s.velocities, s.densities});
}

void SimulationHost::Publish(bool force, bool discontinuity) {
  const uint32_t fields = hub_.NeededFields();
  if (fields == 0) return;  // no one watches: nothing gathered, nothing encoded
  const auto start = Clock::now();
  GatherSnapshot(*sim_, fields, snapshot_);
  gather_.Add(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
  publisher_.Offer(snapshot_, force, discontinuity);
}

void SimulationHost::RefreshStatus() {
  // Per frame: the cheap accessors only (on a GPU, state() copies every particle array back).
  HostStatus s;
  s.running = running_;
  s.step = sim_->step();
  s.frame = sim_->frame();
  s.time = sim_->time();
  s.particles = uint32_t(sim_->particle_count());
  s.solver = sim_->scene().solver;
  s.scene = sim_->scene().name;
  if (recent_frames_.size() >= 2 && running_) {
    const double span =
        std::chrono::duration<double>(recent_frames_.back() - recent_frames_.front()).count();
    if (span > 0) s.frames_per_second = double(recent_frames_.size() - 1) / span;
  }
  s.target_frame_rate = options_.frame_rate;
  for (const PassProfile& prof : sim_->profile()) {
    s.passes.push_back(PassStatus{prof.name, prof.last_ms,
                                  prof.calls ? prof.total_ms / double(prof.calls) : 0.0,
                                  prof.calls});
  }
  const auto add_stage = [&](const char* name, const StageTiming& t) {
    if (t.calls > 0) s.passes.push_back(PassStatus{name, t.last_ms, t.mean_ms, t.calls});
  };
  add_stage("gather_frames", gather_);
  add_stage("publish_frames", publisher_.timing());
  s.solver_threads = uint32_t(running_threads_);
  s.alarm = alarm_;
  s.warning = sim_->warning();
  s.device = sim_->DeviceDescription();
  s.device_memory_bytes = sim_->DeviceBytes();
  s.history_frames = history_.available(s.frame);
  s.history_bytes = history_.bytes();
  if (!running_) s.state_hash = StateHash(sim_->state());
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
