#include "dysa/core/history.h"

#include <algorithm>

namespace dysa {

void History::Start(const Simulation& sim) {
  checkpoints_.clear();
  bytes_ = 0;
  // Checkpoints that fit the budget, keeping room for the two extra ones the window can hold
  // transiently (the one being added and the one before the window's start).
  const size_t per_checkpoint = sim.SaveCheckpoint().bytes();
  const uint64_t fit = std::max<uint64_t>(config_.max_bytes / per_checkpoint, 3) - 2;
  const uint64_t wanted = std::max<uint64_t>(config_.frames, 1);
  interval_ = static_cast<int>(
      std::clamp<uint64_t>((wanted + fit - 1) / fit, 1, std::max(config_.max_interval, 1)));
  window_ = std::min<uint64_t>(wanted, fit * interval_);
  Add(sim);
}

void History::Record(const Simulation& sim) {
  const uint64_t frame = sim.frame();
  if (frame % interval_ == 0 && (checkpoints_.empty() || checkpoints_.back().frame < frame)) {
    Add(sim);
  }
  Trim(frame);
}

void History::RecordParameterChange(const Simulation& sim) {
  if (!checkpoints_.empty() && checkpoints_.back().frame == sim.frame()) {
    bytes_ -= checkpoints_.back().bytes();
    checkpoints_.pop_back();
  }
  Add(sim);
  Trim(sim.frame());
}

uint64_t History::Restore(Simulation& sim, uint64_t target) {
  if (checkpoints_.empty()) return sim.frame();  // Start() not called: nothing kept
  target = std::max(target, oldest_frame());
  // The newest checkpoint at or before target (there is one: the oldest is at or before it).
  while (checkpoints_.size() > 1 && checkpoints_.back().frame > target) {
    bytes_ -= checkpoints_.back().bytes();
    checkpoints_.pop_back();
  }
  sim.RestoreCheckpoint(checkpoints_.back());
  while (sim.frame() < target) sim.StepFrame();
  return target;
}

uint64_t History::oldest_frame() const {
  return checkpoints_.empty() ? 0 : checkpoints_.front().frame;
}

void History::Add(const Simulation& sim) {
  checkpoints_.push_back(sim.SaveCheckpoint());
  bytes_ += checkpoints_.back().bytes();
}

void History::Trim(uint64_t current_frame) {
  const uint64_t keep_from = current_frame > window_ ? current_frame - window_ : 0;
  // Drop the oldest while the next one still reaches the window's start, then while over budget
  // (parameter changes add checkpoints off the interval); the newest always stays.
  while (checkpoints_.size() > 1 &&
         (checkpoints_[1].frame <= keep_from || bytes_ > config_.max_bytes)) {
    bytes_ -= checkpoints_.front().bytes();
    checkpoints_.pop_front();
  }
}

}  // namespace dysa
