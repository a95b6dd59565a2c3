// Frame history for stepping back: checkpoints every few frames plus deterministic
// re-simulation, within a memory budget.
//
// A checkpoint (Checkpoint, 28 bytes per particle, 36 with dfsph's warm start) is kept every
// `interval` frames and whenever the parameters change without a reset. Going back to frame f
// restores the newest checkpoint at or before f and re-simulates the frames in between; the
// solver is deterministic, so the state reached is bit-identical to the one first simulated. The
// interval is chosen from the budget: 600 frames of the 91,125-particle thesis scene (2.55 MB per
// checkpoint) fit 256 MiB with a checkpoint every 6 frames, so a step back re-simulates at most 5
// frames.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>

#include "dysa/core/simulation.h"

namespace dysa {

struct HistoryConfig {
  uint64_t frames = 600;                 // frames StepBack can reach, at least (when the budget
                                         // allows it with checkpoints at most max_interval apart)
  size_t max_bytes = size_t{256} << 20;  // memory all checkpoints together may use
  int max_interval = 16;  // frames between checkpoints at most: bounds the cost of one step back
};

class History {
 public:
  explicit History(HistoryConfig config = {}) : config_(config) {}

  // Forgets everything and starts from the simulation's current frame (after a reset or a new
  // scene); sizes the interval and the window for this particle count.
  void Start(const Simulation& sim);
  // After each new frame: keeps a checkpoint when one is due and drops the ones no longer
  // needed to reach the window's oldest frame, or over the memory budget.
  void Record(const Simulation& sim);
  // After a parameter change that did not reset: the frames from here on use new parameters, so
  // re-simulation must start from a checkpoint taken now.
  void RecordParameterChange(const Simulation& sim);
  // Moves the simulation back to frame max(target, oldest_frame()) and returns that frame.
  // Checkpoints after it are dropped: the frames that follow are simulated (again) from here.
  uint64_t Restore(Simulation& sim, uint64_t target);

  uint64_t oldest_frame() const;
  // Frames StepBack can go back from `current_frame`.
  uint64_t available(uint64_t current_frame) const { return current_frame - oldest_frame(); }
  size_t bytes() const { return bytes_; }
  int interval() const { return interval_; }
  uint64_t window() const { return window_; }  // frames kept (may be less than asked: budget)
  size_t checkpoints() const { return checkpoints_.size(); }

 private:
  void Add(const Simulation& sim);
  void Trim(uint64_t current_frame);

  HistoryConfig config_;
  int interval_ = 1;
  uint64_t window_ = 0;
  std::deque<Checkpoint> checkpoints_;  // by frame, oldest first
  size_t bytes_ = 0;
};

}  // namespace dysa
