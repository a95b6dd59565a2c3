// What each control does to the simulation thread's state: SimulationHost::Apply for the
// controls answered at once, BeginStep/ContinueStep/FinishStep for a Step, which advances frame
// by frame between other controls.
#include <sstream>

#include "control_queue.h"
#include "dysa/core/types.h"
#include "dysa/service/simulation_host.h"

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

ControlResult CountOutOfRange() {
  return ControlError(ControlCode::kInvalidArgument,
                      "count: allowed range [1, " + std::to_string(kMaxStepCount) + "] frames");
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

ControlCode CallerGone(const ControlCaller& caller, Clock::time_point now) {
  if (caller.cancelled && caller.cancelled()) return ControlCode::kCancelled;
  if (caller.deadline != Clock::time_point::max() && now + kReplyMargin > caller.deadline) {
    return ControlCode::kDeadlineExceeded;
  }
  return ControlCode::kOk;
}

ControlResult ControlError(ControlCode code, std::string message) {
  ControlResult result;
  result.code = code;
  result.message = std::move(message);
  return result;
}

void SimulationHost::BeginStep(QueuedControl& job) {
  const StepControl& c = std::get<StepControl>(job.control);
  if (c.count < 1 || c.count > kMaxStepCount) {
    Answer(job, CountOutOfRange());
    return;
  }
  if (!alarm_.empty()) {
    Answer(job, ControlError(ControlCode::kFailedPrecondition,
                             "cannot step: " + alarm_ + " (StepBack or Reset first)"));
    return;
  }
  if (running_) Log("paused at frame " + std::to_string(sim_->frame()) + " to step");
  running_ = false;
  // A frame in progress (the simulation was running) is the Step's first.
  step_ = ActiveStep{std::make_unique<QueuedControl>(std::move(job)), c.count, 0};
  RefreshStatus();
}

void SimulationHost::ContinueStep() {
  ActiveStep& step = *step_;
  // The Step ends early enough for its frame to land (options_.landing_budget) and its answer
  // to reach the caller in time (kReplyMargin).
  const auto gone = [&] {
    ControlCaller caller = step.job->caller;
    if (caller.deadline != Clock::time_point::max()) caller.deadline -= options_.landing_budget;
    return CallerGone(caller, Clock::now());
  };
  if (const ControlCode why = gone(); why == ControlCode::kCancelled) {
    FinishStep(ControlError(why, "cancelled by its caller"), "its caller cancelled it");
    return;
  } else if (why == ControlCode::kDeadlineExceeded) {
    // Answered while the caller still waits: the frames moved are reported.
    FinishStep(ControlResult{}, "its caller's deadline is near");
    return;
  }
  const bool complete =
      AdvanceFrame([&] { return queue_->attention() || gone() != ControlCode::kOk; });
  if (complete && alarm_.empty()) ++step.moved;
  if (!alarm_.empty()) {
    FinishStep(ControlResult{}, "the simulation diverged");
  } else if (step.moved == step.count) {
    FinishStep(ControlResult{}, "");
  }
}

void SimulationHost::FinishStep(ControlResult result, const std::string& why) {
  // Ending inside a frame, the Step leaves the simulation on one: finished (which counts as a
  // frame moved), or rolled back.
  const uint64_t before = sim_->frame();
  LandOnFrame();
  step_->moved += uint32_t(sim_->frame() - before);
  ActiveStep step = std::move(*step_);
  step_.reset();
  if (!why.empty()) {
    Log("Step of " + std::to_string(step.count) + " frames ended after " +
        std::to_string(step.moved) + ": " + why);
  }
  result.frames_moved = step.moved;
  Answer(*step.job, std::move(result));
}

ControlResult SimulationHost::Apply(Control& control) {
  return std::visit(
      Overloaded{
          [&](PauseControl&) {
            if (running_) Log("paused at frame " + std::to_string(sim_->frame()));
            running_ = false;
            LandOnFrame();
            return ControlResult{};
          },
          [&](ResumeControl&) {
            if (!alarm_.empty()) {
              return ControlError(ControlCode::kFailedPrecondition,
                                  "cannot resume: " + alarm_ + " (StepBack or Reset first)");
            }
            if (!running_) Log("resumed at frame " + std::to_string(sim_->frame()));
            running_ = true;
            return ControlResult{};
          },
          [&](StepControl&) {
            // Never reached: Handle hands Steps to BeginStep, which answers them later.
            return ControlError(ControlCode::kFailedPrecondition, "Step is not applied at once");
          },
          [&](StepBackControl& c) {
            if (c.count < 1 || c.count > kMaxStepCount) return CountOutOfRange();
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
                return ControlError(ControlCode::kResourceExhausted, over);
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
                params_changed_in_frame_ = true;  // recorded where the frame lands
              } else {
                history_.RecordParameterChange(*sim_);
              }
              return r;
            } catch (const ConfigError& e) {
              return ControlError(ControlCode::kInvalidArgument, e.what());
            }
          },
          [&](LoadSceneControl& c) {
            if (const std::string over = CheckParticleLimit(c.scene, c.scene.params);
                !over.empty()) {
              return ControlError(ControlCode::kResourceExhausted, over);
            }
            try {
              // On a GPU, a solver without a GPU backend fails here (ConfigError "device"):
              // the old scene runs on.
              auto next = MakeSimulation(std::move(c.scene));
              sim_ = std::move(next);
            } catch (const ConfigError& e) {
              return ControlError(ControlCode::kInvalidArgument, e.what());
            }
            DescribeScene();
            StartScene();
            ControlResult r;
            r.reset = true;
            return r;
          },
      },
      control);
}

}  // namespace dysa::service
