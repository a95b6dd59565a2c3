// DetailController against a simulated link: a fake clock, frames produced at a fixed rate, a
// link of a given byte rate that writes one frame at a time (newest frame wins, as the hub does).
#include "dysa/service/detail_controller.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <stdexcept>
#include <vector>

namespace dysa::service {
namespace {

struct SimResult {
  std::vector<double> delivered_at;  // s, each delivered frame
  std::vector<size_t> delivered_bytes;
  std::vector<std::pair<double, int>> levels;  // (time, level) at each frame start
};

// Frames of `total` particles at `fps`, for `seconds`; `rate(t)` bytes/s. A frame costs 2.6
// bytes per particle (5.6 for a keyframe: the first at each level, then every 60 frames).
class SimulatedLink {
 public:
  SimulatedLink(DetailController& c, uint32_t total, double fps, std::function<double(double)> rate)
      : c_(c), total_(total), fps_(fps), rate_(std::move(rate)) {}

  void Run(double until, SimResult& out) {
    const double dt = 1.0 / fps_;
    for (; t_ < until; t_ += dt, ++frame_) {
      // Finish the frame in flight as far as the link gets by now.
      Advance(t_, out);
      if (sending_) {
        c_.OnLate(t_);  // the next frame is ready while this one is still being written
        continue;       // newest wins: this frame is skipped
      }
      Start(t_, out);
      Advance(t_, out);
    }
  }

 private:
  void Start(double now, SimResult& out) {
    const int level = c_.level();
    const uint32_t particles =
        uint32_t(std::llround(DetailController::LevelFraction(level) * total_));
    const bool key = level != sent_level_ || since_key_ >= 60;
    since_key_ = key ? 1 : since_key_ + 1;
    sent_level_ = level;
    bytes_ = size_t((key ? 5.6 : 2.6) * particles) + 150;
    left_ = double(bytes_);
    c_.OnSourceFrame(frame_, now - 0.002);
    c_.OnFrameStart(now, bytes_, particles, total_, key, now - 0.002);
    out.levels.emplace_back(now, level);
    sending_ = true;
    link_t_ = now;
  }
  // The link writes at rate(t), integrated in 1 ms steps.
  void Advance(double now, SimResult& out) {
    while (sending_ && link_t_ < now + 1e-12) {
      const double step = 1e-3;
      left_ -= rate_(link_t_) * step;
      link_t_ += step;
      if (left_ <= 0) {
        sending_ = false;
        c_.OnBytesDelivered(link_t_, bytes_, true);
        out.delivered_at.push_back(link_t_);
        out.delivered_bytes.push_back(bytes_);
      }
    }
  }

  DetailController& c_;
  uint32_t total_;
  double fps_;
  std::function<double(double)> rate_;
  double t_ = 0, link_t_ = 0, left_ = 0;
  bool sending_ = false;
  size_t bytes_ = 0;
  int sent_level_ = -1, since_key_ = 0;
  uint64_t frame_ = 0;  // the source's frame number (skipped frames count)
};

int LevelChanges(const SimResult& r, double from, double to) {
  int changes = 0;
  for (size_t i = 1; i < r.levels.size(); ++i) {
    if (r.levels[i].first >= from && r.levels[i].first < to &&
        r.levels[i].second != r.levels[i - 1].second) {
      ++changes;
    }
  }
  return changes;
}

double FramesPerSecond(const SimResult& r, double from, double to) {
  return double(std::count_if(r.delivered_at.begin(), r.delivered_at.end(),
                              [&](double t) { return t >= from && t < to; })) /
         (to - from);
}

double BytesPerSecond(const SimResult& r, double from, double to) {
  double bytes = 0;
  for (size_t i = 0; i < r.delivered_at.size(); ++i) {
    if (r.delivered_at[i] >= from && r.delivered_at[i] < to) bytes += double(r.delivered_bytes[i]);
  }
  return bytes / (to - from);
}

double MaxGap(const SimResult& r, double from, double to) {
  double gap = 0, last = from;
  for (double t : r.delivered_at) {
    if (t < from || t >= to) continue;
    gap = std::max(gap, t - last);
    last = t;
  }
  return std::max(gap, to - last);
}

constexpr uint32_t kParticles = 100000;

TEST(DetailController, ConvergesToTheDetailThatFitsAndHoldsIt) {
  // 2 MB/s at 30 fps: 66,667 bytes a frame, 25,600 particles at 2.6 bytes: a fraction of 0.256.
  DetailController c({.fps_target = 30});
  SimulatedLink link(c, kParticles, 30, [](double) { return 2e6; });
  SimResult r;
  link.Run(40, r);
  EXPECT_LE(c.fraction(), 0.257);
  EXPECT_GT(c.fraction(), 0.256 * 0.8 / 1.19);  // within the dead band below the fit
  EXPECT_GE(FramesPerSecond(r, 20, 40), 29.0);  // the frame-rate target is held
  EXPECT_EQ(LevelChanges(r, 10, 40), 0) << "no oscillation at steady state";
  const DetailStatus s = c.Status(40);
  EXPECT_NEAR(s.frames_per_second, 30, 3);
  EXPECT_NEAR(s.bytes_per_second, BytesPerSecond(r, 30, 40), 0.15 * BytesPerSecond(r, 30, 40));
  EXPECT_NEAR(s.link_bytes_per_second, 2e6, 0.1e6);  // the link model's 1 ms steps
  EXPECT_GT(s.age_s, 0);
  EXPECT_LT(s.age_s, 0.1);
}

// A source slower than the target: the simulation makes 3 frames/s, the subscriber asks for
// 30. Spread over 30 frames/s the 2 MB/s link would allow a quarter of the particles (above);
// every frame the source makes fits it whole (260 KB x 3 = 0.78 MB/s), so the detail is full.
TEST(DetailController, ASourceSlowerThanTheTargetGetsTheDetailItsOwnRateFits) {
  DetailController c({.fps_target = 30});
  SimulatedLink link(c, kParticles, 3, [](double) { return 2e6; });
  SimResult r;
  link.Run(30, r);
  EXPECT_EQ(c.fraction(), 1.0);
  EXPECT_NEAR(c.source_fps(), 3, 0.01);
  EXPECT_NEAR(c.fitted_fps(), 3, 0.01);
  EXPECT_GE(FramesPerSecond(r, 10, 30), 2.9) << "every frame the source makes";
  EXPECT_EQ(LevelChanges(r, 10, 30), 0);
  // A source of 15 frames/s on a 2 MB/s link: 133 KB a frame, about half of the particles.
  DetailController faster({.fps_target = 30});
  SimulatedLink link15(faster, kParticles, 15, [](double) { return 2e6; });
  SimResult r15;
  link15.Run(30, r15);
  EXPECT_NEAR(faster.fitted_fps(), 15, 0.01);
  EXPECT_LE(faster.fraction(), 0.52);
  EXPECT_GT(faster.fraction(), 0.3);
  EXPECT_GE(FramesPerSecond(r15, 10, 30), 14.5);
}

TEST(DetailController, RecoversAfterABurstWithoutStalling) {
  // The link drops to a tenth for 3 s, then comes back.
  auto rate = [](double t) { return t >= 20 && t < 23 ? 2e5 : 2e6; };
  DetailController c({.fps_target = 30});
  SimulatedLink link(c, kParticles, 30, rate);
  SimResult r;
  link.Run(20, r);
  const int steady = c.level();
  link.Run(23, r);
  EXPECT_GE(c.level(), steady + 8) << "the detail dropped with the link";
  EXPECT_LT(MaxGap(r, 20, 23), 0.7) << "frames kept coming during the burst";
  EXPECT_GE(FramesPerSecond(r, 21.5, 23), 20.0);
  link.Run(60, r);
  EXPECT_LE(std::abs(c.level() - steady), 1) << "back to the detail the link allows";
  EXPECT_EQ(LevelChanges(r, 45, 60), 0);
  EXPECT_GE(FramesPerSecond(r, 30, 60), 29.0);
}

TEST(DetailController, RespectsTheParticleBudget) {
  DetailController c({.fps_target = 30, .particles_per_frame = 10000});
  SimulatedLink link(c, kParticles, 30, [](double) { return 1e9; });  // a fast link
  SimResult r;
  link.Run(10, r);
  for (const auto& [t, level] : r.levels) {
    if (t > 0.1) {
      EXPECT_LE(DetailController::LevelFraction(level) * kParticles, 10000.0) << t;
    }
  }
  // The largest detail within the budget: one level up would exceed it.
  EXPECT_GT(DetailController::LevelFraction(c.level() - 1) * kParticles, 10000.0);
}

TEST(DetailController, RespectsTheByteBudget) {
  DetailController c({.fps_target = 30, .bytes_per_second = 500000});
  SimulatedLink link(c, kParticles, 30, [](double) { return 1e9; });
  SimResult r;
  link.Run(30, r);
  EXPECT_LE(BytesPerSecond(r, 10, 30), 500000 * 1.02);
  EXPECT_GE(BytesPerSecond(r, 10, 30), 500000 * 0.6);
  EXPECT_EQ(LevelChanges(r, 10, 30), 0);
}

TEST(DetailController, LatenessDecreasesAtOnceAndIncreasesAreSlow) {
  DetailController c({.fps_target = 30});
  c.OnFrameStart(0, 260000, 100000, 100000, false, 0);
  c.OnLate(0.033);
  EXPECT_EQ(c.level(), 2) << "multiplicative decrease (x 0.71)";
  c.OnLate(0.066);
  EXPECT_EQ(c.level(), 2) << "once per frame at the new level";
  // The link was only slow for a moment: frames now go out at 50 MB/s. One level up per hold
  // time (0.5 s), not at once.
  auto send_until = [&](double& t, double until) {
    for (; t < until; t += 1.0 / 30) {
      const auto particles = uint32_t(c.fraction() * 100000);
      const auto bytes = size_t(2.6 * particles);
      c.OnFrameStart(t, bytes, particles, 100000, false, t);
      c.OnBytesDelivered(t + bytes / 5e7, bytes, true);
    }
  };
  double t = 0.1;
  send_until(t, 0.5);
  EXPECT_EQ(c.level(), 2);
  send_until(t, 0.9);
  EXPECT_EQ(c.level(), 1);
  send_until(t, 1.4);
  EXPECT_EQ(c.level(), 0);
}

TEST(DetailController, WithoutABudgetTheDetailStaysWhole) {
  DetailController c({});
  SimulatedLink link(c, kParticles, 30, [](double) { return 1e5; });  // far too slow
  SimResult r;
  link.Run(12, r);
  EXPECT_EQ(c.level(), 0);
  EXPECT_EQ(c.threshold(), 0u);
  EXPECT_GT(c.Status(12).bytes_per_second, 0);
}

TEST(DetailController, BudgetsOutOfRangeNameTheirField) {
  auto message = [](DetailBudget b) {
    try {
      b.Validate();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(message({.fps_target = 30, .bytes_per_second = 1e6, .particles_per_frame = 5}), "");
  EXPECT_NE(message({.fps_target = -1}).find("fps_target: allowed range [0, 1000]"),
            std::string::npos);
  EXPECT_NE(message({.fps_target = NAN}).find("fps_target"), std::string::npos);
  EXPECT_NE(message({.fps_target = 30, .bytes_per_second = 10}).find("byte_budget"),
            std::string::npos);
  EXPECT_NE(message({.bytes_per_second = 1e6}).find("byte_budget: needs fps_target"),
            std::string::npos);
  EXPECT_NE(message({.particles_per_frame = 30'000'000}).find("particle_budget"),
            std::string::npos);
}

}  // namespace
}  // namespace dysa::service
