#include "dysa/service/detail_controller.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

#include "dysa/codec/detail_subset.h"

namespace dysa::service {
namespace {

constexpr double kTau = 1.0;        // s, the smoothing of every rate
constexpr double kUpShare = 0.8;    // the next level must fit in 80% of the link to go up
constexpr double kDownShare = 1.0;  // the current level must fit in all of it to stay
constexpr int kLateStep = 2;        // levels down on lateness: x 0.71
constexpr double kBaseHold = 0.5;   // s of headroom before a level up
constexpr double kMaxHold = 8.0;

double Decay(double dt) { return std::exp(-std::max(0.0, dt) / kTau); }

}  // namespace

void DetailBudget::Validate() const {
  auto check = [](bool ok, const std::string& field, const std::string& range) {
    if (!ok) throw std::invalid_argument(field + ": allowed range " + range);
  };
  check(std::isfinite(fps_target) && fps_target >= 0 && fps_target <= 1000, "fps_target",
        "[0, 1000] frames per second (0: none)");
  check(std::isfinite(bytes_per_second) && bytes_per_second >= 0 &&
            (bytes_per_second == 0 || bytes_per_second >= 1000),
        "byte_budget", "0 (none) or [1000, inf) bytes per second");
  if (bytes_per_second > 0 && fps_target == 0) {
    throw std::invalid_argument(
        "byte_budget: needs fps_target > 0 (bytes per second are spread "
        "over the target frame rate)");
  }
  check(particles_per_frame <= 20'000'000, "particle_budget",
        "0 (none) or [1, 20000000] particles per frame");
}

double DetailController::LevelFraction(int level) { return std::exp2(-0.25 * level); }

DetailController::DetailController(DetailBudget budget) : budget_(budget) {}

uint32_t DetailController::threshold() const {
  return level_ == 0 ? 0 : codec::DetailThreshold(fraction());
}

double SteadySeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

void DetailController::SetTotal(double now, uint32_t total) {
  total_ = total;
  Decide(now);
}

void DetailController::OnFrameStart(double now, size_t bytes, uint32_t particles, uint32_t total,
                                    bool keyframe, double produced) {
  frame_start_ = now;
  frame_bytes_ = bytes;
  frame_particles_ = particles;
  frame_keyframe_ = keyframe;
  frame_level_ = level_;
  frame_produced_ = produced;
  if (particles > 0) {
    double& bpp = keyframe ? key_bpp_ : delta_bpp_;
    bpp += 0.25 * (double(bytes) / particles - bpp);
  }
  if (total != total_) {
    total_ = total;
    Decide(now);  // the particle budget's level moves with the scene
  }
}

void DetailController::OnBytesDelivered(double now, size_t bytes, bool frame_done) {
  const double decay = Decay(now - rates_at_);
  bytes_sum_ = bytes_sum_ * decay + double(bytes);
  frames_sum_ = frames_sum_ * decay + (frame_done ? 1.0 : 0.0);
  rates_at_ = now;
  if (!frame_done) return;
  shown_produced_ = frame_produced_;
  shown_particles_ = frame_particles_;
  const double took = now - frame_start_;
  if (took > 1e-4 && frame_bytes_ > 0) {
    const double sample = double(frame_bytes_) / took;
    const double alpha = link_ ? std::clamp(1.0 - Decay(now - link_sampled_at_), 0.05, 1.0) : 1.0;
    link_ = link_ ? *link_ + alpha * (sample - *link_) : sample;
    link_sampled_at_ = now;
  }
  if (frame_level_ == level_) late_blocked_ = false;
  Decide(now);
}

void DetailController::OnLate(double now) {
  if (budget_.fps_target <= 0 || frame_keyframe_ || late_blocked_) return;
  last_late_ = now;
  if (now - last_increase_ < 2 * up_hold_ + 1.0) up_hold_ = std::min(kMaxHold, 2 * up_hold_);
  level_ = std::min(kLevels - 1, level_ + kLateStep);
  late_blocked_ = true;
  headroom_since_.reset();
}

bool DetailController::Fits(int level, double share) const {
  if (budget_.fps_target <= 0) return true;
  double available = link_ ? share * *link_ : INFINITY;
  if (budget_.bytes_per_second > 0) {
    available = std::min(available, (share < 1 ? 0.9 : 1.0) * budget_.bytes_per_second);
  }
  const double frame_bytes = delta_bpp_ * LevelFraction(level) * total_ + 200.0;  // + headers
  return frame_bytes * budget_.fps_target <= available;
}

int DetailController::BudgetLevel() const {
  if (budget_.particles_per_frame == 0 || total_ == 0) return 0;
  int level = 0;
  while (level + 1 < kLevels && LevelFraction(level) * total_ > budget_.particles_per_frame) {
    ++level;
  }
  return level;
}

void DetailController::Decide(double now) {
  if (!budget_.active()) return;
  const int floor = BudgetLevel();
  if (level_ < floor) {
    level_ = floor;
    headroom_since_.reset();
    return;
  }
  if (!Fits(level_, kDownShare)) {
    // Multiplicative decrease: straight to the level that fits with headroom.
    while (level_ + 1 < kLevels && !Fits(level_, kUpShare)) ++level_;
    headroom_since_.reset();
    return;
  }
  if (level_ > floor && Fits(level_ - 1, kUpShare)) {
    if (!headroom_since_) headroom_since_ = now;
    if (now - *headroom_since_ >= up_hold_) {
      --level_;
      last_increase_ = now;
      headroom_since_ = now;  // the next level needs a hold of its own
      if (now - last_late_ > 4 * kMaxHold) up_hold_ = kBaseHold;
    }
    return;
  }
  headroom_since_.reset();
}

DetailStatus DetailController::Status(double now) const {
  DetailStatus s;
  s.fraction = fraction();
  s.particles = shown_particles_;
  const double decay = Decay(now - rates_at_);
  s.bytes_per_second = bytes_sum_ * decay / kTau;
  s.frames_per_second = frames_sum_ * decay / kTau;
  s.age_s = shown_produced_ ? std::max(0.0, now - *shown_produced_) : 0.0;
  s.link_bytes_per_second = link_.value_or(0.0);
  return s;
}

}  // namespace dysa::service
