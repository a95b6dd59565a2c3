// The frame contract of a simulation stepped between controls.
//
// Frames advance in pieces, so that a control acts between any two solver steps (a frame of a
// physical solver is many adaptive steps, and a scene can make each of them slow). But a paused
// simulation must be on a frame: the frame its subscribers were last sent, the one its status
// describes (frame, step, time, state hash), and one that Step and StepBack return to bit for
// bit. So wherever the simulation stops, the frame in progress lands on a frame boundary
// (SimulationHost::LandOnFrame):
//
//  - finished, when its remaining steps are expected to end within the landing budget
//    (HostOptions::landing_budget, 100 ms): the pause then shows the frame's end;
//  - otherwise rolled back to its start, which this class kept: the pause shows the frame's
//    start, and the next Step or Resume simulates the frame again (deterministic: the same bits).
//
// A pause thus lands within the step in flight plus the budget. Keeping a frame's start costs a
// checkpoint copy (28-36 bytes a particle; from device memory on a GPU), so it is kept only for
// frames expected to outlast half the budget, judged from the last frame's step count and the
// measured wall time per step; a shorter frame is finished. Between half the budget and the
// budget, where finishing is still expected to land in time, it is kept only while the copy
// costs at most a quarter of the frame (WorthKeeping). Only when a frame turns out far longer
// than the last one (the CFL step collapsing, say) can a pause land later than that.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>

#include "dysa/core/simulation.h"

namespace dysa::service {

class FrameStepper {
 public:
  using Clock = std::chrono::steady_clock;

  explicit FrameStepper(Clock::duration landing_budget) : budget_(landing_budget) {}

  // Advances the frame in progress, or begins one (keeping its start when it is expected to be
  // long), until it completes (true) or `interrupted()` stops it between two steps (false):
  // Simulation::StepFrame(interrupted), timed.
  bool Advance(Simulation& sim, const std::function<bool()>& interrupted);

  // The start of the frame in progress is kept: RollBack can return to it.
  bool CanRollBack(const Simulation& sim) const;
  // The frame in progress is expected to be complete by `deadline` if stepped on now (always
  // true when it cannot be rolled back: then it must be finished).
  bool ExpectFinishedBy(const Simulation& sim, Clock::time_point deadline) const;
  // One more step is expected to end by `deadline`.
  bool ExpectStepEndsBy(Clock::time_point deadline) const;
  // Returns the simulation to the start of the frame in progress (CanRollBack), keeping the
  // current parameters: a change made within the frame then holds from its start.
  void RollBack(Simulation& sim);

  // A new scene: what was measured of the old one no longer predicts anything.
  void Forget();

  Clock::duration budget() const { return budget_; }
  double step_seconds() const { return step_seconds_; }  // wall time per step, smoothed; 0: none
  // Frame starts kept so far, and the wall time the latest took (the checkpoint's copy).
  uint64_t keeps() const { return keeps_; }
  double last_keep_ms() const { return last_keep_ms_; }

  // Whether to keep the start of a frame whose steps are expected to take `frame_s` seconds,
  // `tail_s` of them after its first step, when keeping costs `keep_s` (0: not measured yet) and
  // the landing budget is `budget_s`: always when the tail outlasts the budget; never when it
  // fits half of it; in between only while keeping costs at most kKeepShare of the frame.
  static constexpr double kKeepShare = 0.25;
  static bool WorthKeeping(double tail_s, double frame_s, double keep_s, double budget_s);

 private:
  bool ExpectLongFrame() const;

  const Clock::duration budget_;
  Checkpoint start_;         // the start of the frame in progress, while start_kept_
  bool start_kept_ = false;  // for the frame numbered start_.frame
  double step_seconds_ = 0;
  uint64_t frame_first_step_ = 0;  // Simulation::step() when the frame in progress began
  uint64_t last_frame_steps_ = 0;  // steps the latest complete frame took; 0: none yet
  uint64_t keeps_ = 0;
  double last_keep_ms_ = 0;
};

}  // namespace dysa::service
