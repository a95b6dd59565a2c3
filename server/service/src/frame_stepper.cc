#include "dysa/service/frame_stepper.h"

namespace dysa::service {

namespace {
// Weight of the newest measurement in the smoothed wall time per step: a few calls follow a
// change of pace (a parameter change, a splash) without one slow call deciding alone.
constexpr double kSmoothing = 0.25;
}  // namespace

bool FrameStepper::WorthKeeping(double tail_s, double frame_s, double keep_s, double budget_s) {
  if (tail_s > budget_s) return true;  // finishing would land late
  if (tail_s <= 0.5 * budget_s) return false;
  // Finishing is expected to land in time, within half the budget's margin: keeping the start is
  // insurance against slower steps, worth it while it costs a fraction of the frame. (On a GPU
  // the copy crosses to the host: 320 MB a frame at 10 M particles.)
  return keep_s <= kKeepShare * frame_s;
}

bool FrameStepper::ExpectLongFrame() const {
  if (last_frame_steps_ == 0 || step_seconds_ <= 0) return true;  // nothing measured yet
  // Landing interrupts a frame after its first step at the earliest: what may be left is the
  // frame less one step.
  const double tail = double(last_frame_steps_ - 1) * step_seconds_;
  const double frame = double(last_frame_steps_) * step_seconds_;
  return WorthKeeping(tail, frame, 1e-3 * last_keep_ms_,
                      std::chrono::duration<double>(budget_).count());
}

bool FrameStepper::Advance(Simulation& sim, const std::function<bool()>& interrupted) {
  if (!sim.frame_in_progress()) {
    frame_first_step_ = sim.step();
    start_kept_ = ExpectLongFrame();
    if (start_kept_) {
      const auto keep_begin = Clock::now();
      sim.SaveCheckpoint(start_);  // into the last frame's buffers
      last_keep_ms_ = std::chrono::duration<double, std::milli>(Clock::now() - keep_begin).count();
      ++keeps_;
    }
  }
  const auto begin = Clock::now();
  const uint64_t first = sim.step();
  const bool complete = sim.StepFrame(interrupted);
  if (const uint64_t steps = sim.step() - first; steps > 0) {
    const double per_step =
        std::chrono::duration<double>(Clock::now() - begin).count() / double(steps);
    step_seconds_ =
        step_seconds_ > 0 ? step_seconds_ + kSmoothing * (per_step - step_seconds_) : per_step;
  }
  if (complete) {
    last_frame_steps_ = sim.step() - frame_first_step_;
    start_kept_ = false;
  }
  return complete;
}

bool FrameStepper::CanRollBack(const Simulation& sim) const {
  return start_kept_ && sim.frame_in_progress() && start_.frame == sim.frame();
}

bool FrameStepper::ExpectFinishedBy(const Simulation& sim, Clock::time_point deadline) const {
  if (!CanRollBack(sim)) return true;
  const double left = sim.FrameStepsLeft() * step_seconds_;
  return Clock::now() +
             std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(left)) <=
         deadline;
}

bool FrameStepper::ExpectStepEndsBy(Clock::time_point deadline) const {
  return Clock::now() + std::chrono::duration_cast<Clock::duration>(
                            std::chrono::duration<double>(step_seconds_)) <=
         deadline;
}

void FrameStepper::RollBack(Simulation& sim) {
  start_.params = sim.params();
  sim.RestoreCheckpoint(start_);
  start_kept_ = false;
}

void FrameStepper::Forget() {
  start_kept_ = false;
  start_ = {};
  step_seconds_ = 0;
  last_frame_steps_ = 0;
}

}  // namespace dysa::service
