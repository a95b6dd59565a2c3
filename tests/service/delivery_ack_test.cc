// DetailController with a real delivery signal: a simulated link behind a transport that buffers
// (a write completes once the bytes are in a 4 MiB send buffer, as with gRPC over TCP), drained
// at the link's rate, and a client that acknowledges each frame one delay after it arrived. Write
// completions then measure the transport (fast); acknowledgements must measure the link.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <iostream>
#include <optional>

#include "dysa/service/detail_controller.h"

namespace dysa::service {
namespace {

constexpr uint32_t kParticles = 200000;
constexpr double kFps = 25;
constexpr double kLink = 2e6;        // bytes/s the link drains (unless a test sets its own)
constexpr double kTransport = 1e9;   // bytes/s the transport takes a write at
constexpr double kBuffer = 4 << 20;  // bytes the transport holds
constexpr double kAckDelay = 0.02;   // s from arrival to the server hearing of it
constexpr double kTick = 1e-4;       // s, the simulation's time step

struct LinkRun {
  double link_estimate = 0;                                      // the controller's, at the end
  double max_age = 0;                                            // status age over the last half
  double frames_per_second = 0, delivered_bytes_per_second = 0;  // status, at the end
  double half_s = 0;                                             // s, the last half's length
  int frames_arrived = 0;                                        // in the last half
  double max_arrival_age = 0;  // of each frame on arrival, in the last half
  double first_arrival = -1;   // s, when the client had its first frame
  size_t first_bytes = 0;      // its size
  double whole_at = -1;        // s, when the first frame of every particle started
};

struct LinkSetup {
  bool acks = true;  // whether the client reports frames
  double seconds = 12;
  double link = kLink;  // bytes/s
  uint32_t particles = kParticles;
};

LinkRun Simulate(const LinkSetup& setup) {
  const bool acks = setup.acks;
  const double seconds = setup.seconds;
  const double link = setup.link;
  const uint32_t total = setup.particles;
  DetailBudget budget;
  budget.fps_target = kFps;
  DetailController c(budget);
  if (acks) c.ExpectAcknowledgements();  // the stream was opened with an ack token
  c.SetTotal(0, total);                  // as the hub does before a stream's first frame
  struct InFlight {
    double end;  // cumulative link bytes at which its last byte arrives
    double produced;
  };
  std::deque<InFlight> queued;          // in the transport or on the link
  std::deque<double> ack_due;           // when each arrival's report reaches the server
  double drained = 0, written = 0;      // cumulative bytes off the link, into the transport
  std::optional<double> write_done_at;  // the write in flight completes then
  size_t write_bytes = 0;
  uint64_t arrived = 0;
  int sent_level = -1, since_key = 0;
  LinkRun run;
  run.half_s = seconds / 2;
  double next_frame = 0;
  std::optional<double> ready;  // a frame produced then waits (held back, or behind a write)
  auto start = [&](double t, double produced) {
    const int level = c.level();
    const auto particles = uint32_t(std::llround(DetailController::LevelFraction(level) * total));
    const bool key = level != sent_level || since_key >= 60;
    since_key = key ? 1 : since_key + 1;
    sent_level = level;
    write_bytes = size_t((key ? 5.6 : 2.6) * particles) + 150;
    if (run.first_bytes == 0) run.first_bytes = write_bytes;
    if (level == 0 && run.whole_at < 0) run.whole_at = t;
    c.OnFrameStart(t, write_bytes, particles, total, key, produced);
    // Room in the buffer first, then the copy at the transport's rate.
    const double room_at = t + std::max(0.0, written + write_bytes - drained - kBuffer) / link;
    write_done_at = room_at + write_bytes / kTransport;
    written += double(write_bytes);
    queued.push_back({written, produced});
  };
  for (double t = 0; t < seconds; t += kTick) {
    // The link drains the transport.
    drained = std::min(written, drained + link * kTick);
    while (!queued.empty() && queued.front().end <= drained + 1e-9) {
      ++arrived;
      if (run.first_arrival < 0) run.first_arrival = t;
      if (t > seconds / 2) {
        ++run.frames_arrived;
        run.max_arrival_age = std::max(run.max_arrival_age, t - queued.front().produced);
      }
      queued.pop_front();
      if (acks) ack_due.push_back(t + kAckDelay);
    }
    bool reported_now = false;
    uint64_t reported = arrived - ack_due.size();
    while (!ack_due.empty() && ack_due.front() <= t) {
      ack_due.pop_front();
      ++reported;
      c.OnAcknowledged(t, reported, kAckDelay);  // the report's round trip: its own delay
      reported_now = true;
    }
    // The write completes once the transport took it (room in its buffer, at its rate).
    bool written_now = false;
    if (write_done_at && t >= *write_done_at) {
      write_done_at.reset();
      c.OnBytesDelivered(t, write_bytes, true);
      written_now = true;
    }
    if (t >= next_frame) {
      next_frame += 1 / kFps;
      if (write_done_at) c.OnLate(t);  // the newer frame replaces the waiting one
      ready = t - 0.002;
      reported_now = written_now = true;  // try now
    }
    // A waiting frame goes when the write is done and the controller does not hold it back
    // (asked again on each report, as the hub's OnFrameReady does).
    if (ready && !write_done_at && (reported_now || written_now) && !c.Hold(t)) {
      start(t, *ready);
      ready.reset();
    }
    if (t > seconds / 2) run.max_age = std::max(run.max_age, c.Status(t).age_s);
  }
  const DetailStatus s = c.Status(seconds);
  run.link_estimate = s.link_bytes_per_second;
  run.frames_per_second = s.frames_per_second;
  run.delivered_bytes_per_second = s.bytes_per_second;
  return run;
}

TEST(DeliveryAck, WriteCompletionsMeasureTheTransportNotTheLink) {
  const LinkRun r = Simulate({.acks = false});
  std::cout << "link estimate without acknowledgements " << r.link_estimate << " B/s\n";
  // What the link test saw on a real link: the estimate is the transport's rate.
  EXPECT_GT(r.link_estimate, 10 * kLink);
}

TEST(DeliveryAck, AcknowledgementsMeasureTheLinkAndBoundTheAge) {
  const LinkRun r = Simulate({});
  std::cout << "link estimate " << r.link_estimate << " B/s of " << kLink << ", status age max "
            << r.max_age << " s, arrival age max " << r.max_arrival_age << " s, "
            << r.frames_per_second << " frames/s, " << r.delivered_bytes_per_second << " B/s\n";
  EXPECT_NEAR(r.link_estimate, kLink, 0.2 * kLink);
  EXPECT_NEAR(r.frames_per_second, kFps, 0.1 * kFps);
  EXPECT_NEAR(double(r.frames_arrived) / r.half_s, kFps, 0.1 * kFps) << "frames the client got";
  EXPECT_LE(r.delivered_bytes_per_second, 1.05 * kLink);
  // The slow start over (a first keyframe of 64 KiB, doubled per frame until frames queue), the
  // detail settles at what the link allows: the increase rule's dead band leaves between 0.8 / 1.19
  // and 1 of it.
  EXPECT_GE(r.delivered_bytes_per_second, 0.6 * kLink);
  // Data age: two frame periods plus a round trip, as the issue bounds it, both as the status
  // reports it and as the client sees each frame.
  EXPECT_LT(r.max_age, 2 / kFps + 2 * kAckDelay + 0.01);
  EXPECT_LT(r.max_arrival_age, 2 / kFps + 2 * kAckDelay + 0.01);
}

// The slow start on the links the issue names and a slower one. 1 M particles: a full-detail
// first keyframe is 5.6 MB, 45 s at 1 Mbit/s, where the stream showed nothing before.
TEST(DeliveryAck, AStreamStartsSmallAndDoublesUntilTheLinkIsFull) {
  constexpr uint32_t kMillion = 1000000;
  // 1 Mbit/s: the first frame (64 KiB at most) arrives within a second; the detail then settles
  // where the link holds the frame rate.
  const LinkRun slow = Simulate({.seconds = 20, .link = 1.25e5, .particles = kMillion});
  std::cout << "1 Mbit/s: first frame " << slow.first_bytes << " bytes, arrived at "
            << slow.first_arrival << " s; " << slow.frames_per_second << " frames/s, "
            << slow.delivered_bytes_per_second << " B/s at the end\n";
  EXPECT_LE(double(slow.first_bytes), DetailController::kFirstFrameBytes + 200);
  EXPECT_GT(slow.first_arrival, 0);
  EXPECT_LT(slow.first_arrival, 0.6);
  EXPECT_NEAR(slow.frames_per_second, kFps, 0.15 * kFps);
  EXPECT_LE(slow.delivered_bytes_per_second, 1.05 * 1.25e5);
  EXPECT_GE(slow.delivered_bytes_per_second, 0.5 * 1.25e5);
  EXPECT_LT(slow.whole_at, 0) << "never every particle on this link";
  // 1 Gbit/s carries every particle at 25 frames/s (65 MB/s of deltas): the detail doubles per
  // frame from the first and is whole within a second.
  const LinkRun fast = Simulate({.seconds = 4, .link = 1.25e8, .particles = kMillion});
  std::cout << "1 Gbit/s: first frame arrived at " << fast.first_arrival
            << " s, every particle from " << fast.whole_at << " s\n";
  EXPECT_LT(fast.first_arrival, 0.05);
  EXPECT_GE(fast.whole_at, 0);
  EXPECT_LT(fast.whole_at, 1.0);
  EXPECT_NEAR(fast.frames_per_second, kFps, 0.1 * kFps);
}

TEST(DeliveryAck, StaleRepeatedAndExcessiveCountsChangeNothing) {
  DetailBudget budget;
  budget.fps_target = kFps;
  DetailController c(budget);
  c.OnFrameStart(0.0, 1000, 100, 100, true, 0.0);
  c.OnFrameStart(0.04, 1000, 100, 100, false, 0.04);
  c.OnAcknowledged(0.05, 5);  // more than were started: both frames
  EXPECT_EQ(c.frames_acknowledged(), 2u);
  const DetailStatus first = c.Status(0.05);
  EXPECT_NEAR(first.age_s, 0.01, 1e-9) << "the newest acknowledged frame's data";
  c.OnAcknowledged(0.06, 1);  // stale
  c.OnAcknowledged(0.06, 2);  // repeated
  EXPECT_EQ(c.frames_acknowledged(), 2u);
  EXPECT_DOUBLE_EQ(c.Status(0.06).link_bytes_per_second, first.link_bytes_per_second);
}

TEST(DeliveryAck, AClientThatStopsAcknowledgingHoldsBoundedMemory) {
  DetailBudget budget;
  budget.fps_target = kFps;
  DetailController c(budget);
  for (int i = 0; i < 10000; ++i) c.OnFrameStart(i * 0.04, 1000, 100, 100, false, i * 0.04);
  c.OnAcknowledged(400.0, 10000);  // the last 256 are still known; the rest were dropped
  EXPECT_EQ(c.frames_acknowledged(), 10000u);
  EXPECT_NEAR(c.Status(400.0).age_s, 400.0 - 9999 * 0.04, 1e-6);
}

}  // namespace
}  // namespace dysa::service
