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
constexpr double kRttWindow = 10.0;    // s, the window of the smallest round trip
constexpr double kMaxHoldFrame = 5.0;  // s a frame may wait for its report before they stop

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

DetailController::DetailController(DetailBudget budget)
    : budget_(budget), slow_start_(budget.fps_target > 0) {}

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
  sent_.push_back({++started_, bytes, particles, now, produced, level_});
  if (sent_.size() > kMaxUnacknowledged) sent_.pop_front();
  if (particles > 0) {
    double& bpp = keyframe ? key_bpp_ : delta_bpp_;
    bpp += 0.25 * (double(bytes) / particles - bpp);
  }
  if (total != total_) {
    total_ = total;
    Decide(now);  // the particle budget's level moves with the scene
  }
}

void DetailController::OnSourceFrame(uint64_t frame, double produced) {
  // A reset or a step back starts the count afresh; a view stream's completion of the same
  // frame adds nothing.
  if (source_frame_ && frame > *source_frame_ && produced > source_produced_) {
    const double period = (produced - source_produced_) / double(frame - *source_frame_);
    source_period_ =
        source_period_ > 0 ? source_period_ + 0.25 * (period - source_period_) : period;
  } else if (source_frame_ && frame < *source_frame_) {
    source_period_ = 0;
  }
  if (!source_frame_ || frame != *source_frame_) {
    source_frame_ = frame;
    source_produced_ = produced;
  }
}

double DetailController::fitted_fps() const {
  const double source = source_fps();
  return source > 0 ? std::min(budget_.fps_target, source) : budget_.fps_target;
}

void DetailController::OnBytesDelivered(double now, size_t bytes, bool frame_done) {
  if (acknowledged_) {  // the client's acknowledgements measure delivery
    if (frame_done) Decide(now);
    return;
  }
  const double decay = Decay(now - rates_at_);
  bytes_sum_ = bytes_sum_ * decay + double(bytes);
  frames_sum_ = frames_sum_ * decay + (frame_done ? 1.0 : 0.0);
  rates_at_ = now;
  if (!frame_done) return;
  shown_produced_ = frame_produced_;
  shown_particles_ = frame_particles_;
  const double took = now - frame_start_;
  if (took > 1e-4 && frame_bytes_ > 0) SampleLink(now, double(frame_bytes_) / took);
  if (frame_level_ == level_) {
    late_blocked_ = false;
    // A frame that outlasted its period measured the link: the slow start is over.
    if (took * fitted_fps() > 1) slow_start_ = false;
    OnDeliveredAtLevel();
  }
  Decide(now);
}

void DetailController::SampleLink(double now, double sample) {
  const double alpha = link_ ? std::clamp(1.0 - Decay(now - link_sampled_at_), 0.05, 1.0) : 1.0;
  link_ = link_ ? *link_ + alpha * (sample - *link_) : sample;
  link_sampled_at_ = now;
}

bool DetailController::Hold(double now) {
  if (!acknowledged_ || budget_.fps_target <= 0 || sent_.empty()) return false;
  const double oldest = now - sent_.front().start;
  // A client that stopped reporting must not stall its stream: after kMaxHold without a
  // report, write completions measure again.
  if (oldest > kMaxHoldFrame) {
    acknowledged_ = false;
    sent_.clear();
    return false;
  }
  // One frame on its way is never held back: its own transfer is the age it adds. Three frame
  // periods leave room for reports that come late (a busy client or server, a reply queued
  // behind frames): holding is not lateness and never lowers the detail, which the measured
  // link decides; it only keeps the transport's queue short.
  const bool hold = sent_.size() >= 2 && oldest > 3 / budget_.fps_target + rtt_min_;
  if (hold) slow_start_ = false;  // frames back up: the link is full
  return hold;
}

void DetailController::OnAcknowledged(double now, uint64_t frames, double rtt) {
  if (std::isfinite(rtt) && rtt > 0 && (rtt <= rtt_min_ || now - rtt_min_at_ > kRttWindow)) {
    rtt_min_ = rtt;
    rtt_min_at_ = now;
  }
  frames = std::min(frames, started_);
  if (frames <= acked_frames_) return;
  if (!acknowledged_) {
    // What write completions measured was the transport's rate: start afresh.
    ExpectAcknowledgements();
    bytes_sum_ = frames_sum_ = 0;
    link_.reset();
  }
  size_t bytes = 0;
  double count = 0, first_start = INFINITY;
  bool at_level = false;
  while (!sent_.empty() && sent_.front().ordinal <= frames) {
    const Sent& s = sent_.front();
    bytes += s.bytes;
    count += 1;
    first_start = std::min(first_start, s.start);
    shown_produced_ = s.produced;
    shown_particles_ = s.particles;
    // Lateness acts again once a frame at the level it chose has arrived: the frames queued
    // before it say nothing new (a queue of a few MiB drains for seconds on a slow link).
    if (s.level == level_) late_blocked_ = false;
    at_level = at_level || s.level == level_;
    sent_.pop_front();
  }
  acked_frames_ = frames;
  const double decay = Decay(now - rates_at_);
  bytes_sum_ = bytes_sum_ * decay + double(bytes);
  frames_sum_ = frames_sum_ * decay + count;
  rates_at_ = now;
  // The link's time on these bytes, as the server sees it: a frame written at `start` arrives
  // a down-trip later and is reported an up-trip after that. While frames queue on the link
  // (these went out before the frame ahead of them had arrived: start + rtt before the previous
  // report), the link took them from that frame's arrival to theirs, and the up-trips on both
  // ends cancel: bytes / (now - previous report) is its rate. A stream that leaves the link idle
  // between frames adds a round trip and its own delays (writing, reading, a busy CPU) to every
  // interval: bytes / (now - start) is then a lower bound, which may raise the estimate but never
  // lower it (as BBR treats samples it marks application-limited), else a slow spell of the
  // server would lower the detail, and smaller frames would read slower still. (Taking the
  // reported round trip off that interval read 3-4 times the link at 1 Gbit/s: a report's
  // reply queues behind frames, so its round trip overstates the link's.)
  const bool queued = first_start + rtt_min_ < last_ack_;
  const double busy = now - (queued ? last_ack_ : first_start);
  if (bytes > 0 && busy > 1e-4) {
    const double sample = double(bytes) / busy;
    const double keep = Decay(now - link_sampled_at_);
    lower_bound_ = std::max(sample, lower_bound_ * keep);
    if (queued || (link_ && sample > *link_)) {
      // Bytes and busy time are smoothed apart and divided: a mean of per-report rates would
      // weigh the short intervals of reports that come bunched (a report's reply queues behind
      // frames on the same connection) too much, and read high.
      acked_bytes_ = acked_bytes_ * keep + double(bytes);
      acked_busy_ = acked_busy_ * keep + busy;
      link_ = acked_bytes_ / acked_busy_;
    }
    link_sampled_at_ = now;
  }
  last_ack_ = now;
  // Frames queued on the link: it has shown its rate, and the slow start is over.
  if (queued) slow_start_ = false;
  if (at_level) OnDeliveredAtLevel();
  Decide(now);
}

void DetailController::OnDeliveredAtLevel() {
  if (!slow_start_ || !budget_.active()) return;
  const int next = WithinByteBudget(std::max(BudgetLevel(), level_ - kSlowStartStep));
  if (next >= level_) {
    slow_start_ = false;  // at the budgets' detail: nothing left to probe for
    return;
  }
  level_ = next;
}

void DetailController::OnLate(double now) {
  if (budget_.fps_target <= 0) return;
  slow_start_ = false;  // a frame outlasted its period: the link is full
  if (frame_keyframe_ || late_blocked_) return;
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
  return FrameBytes(level, delta_bpp_) * fitted_fps() <= available;
}

double DetailController::FrameBytes(int level, double bytes_per_particle) const {
  return bytes_per_particle * LevelFraction(level) * total_ + 200.0;  // + headers
}

int DetailController::WithinByteBudget(int level) const {
  while (level + 1 < kLevels && budget_.bytes_per_second > 0 &&
         FrameBytes(level, delta_bpp_) * fitted_fps() > budget_.bytes_per_second) {
    ++level;
  }
  return level;
}

int DetailController::FirstFrameLevel() const {
  int level = 0;
  while (level + 1 < kLevels && FrameBytes(level, key_bpp_) > kFirstFrameBytes) ++level;
  return level;
}

int DetailController::BudgetLevel() const {
  if (total_ == 0) return 0;
  // The frame limit holds for the particles a frame actually keeps, a binomial sample of mean
  // m = fraction x total: m + 4 sqrt(m) stays below it (a frame over it would be refused).
  const double limit = double(frame_limit_);
  auto over = [&](int level) {
    const double m = LevelFraction(level) * total_;
    return (budget_.particles_per_frame > 0 && m > double(budget_.particles_per_frame)) ||
           (m < double(total_) && m + 4 * std::sqrt(m) > limit) ||
           (m >= double(total_) && m > limit);
  };
  int level = 0;
  while (level + 1 < kLevels && over(level)) ++level;
  return level;
}

void DetailController::Decide(double now) {
  if (!budget_.active()) return;
  const int floor = BudgetLevel();
  if (slow_start_) {
    // Before the first frame: a keyframe the slowest link takes in about a second. Later the
    // deliveries move the level (OnDeliveredAtLevel), within the budgets.
    if (started_ == 0 && total_ > 0) level_ = FirstFrameLevel();
    level_ = WithinByteBudget(std::max(level_, floor));
    if (level_ > floor) return;
    slow_start_ = false;
  }
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
  s.link_bytes_per_second = link_.value_or(lower_bound_);
  return s;
}

}  // namespace dysa::service
