// The level of detail of one frame stream under a budget: which fraction of the particles to
// send so that the stream holds its frame-rate target on the link it has, within its byte and
// particle budgets. Plain logic on a clock of seconds (no transport, no gRPC): the stream reports
// when each frame's writes start and complete, and when a new frame was ready while the previous
// one was still being written (the link is behind).
//
// How it decides (docs/server.md, "Budgets and detail"):
// - it measures the link while sending (each frame's bytes over the time its writes took,
//   smoothed over ~1 s), the bytes each particle costs (delta frames; keyframes apart), and
//   what the stream delivers (bytes/s and frames/s, exponentially weighted over ~1 s);
// - a write completes when the transport takes the bytes, not when they arrive (gRPC and the
//   kernel buffer megabytes), so once the client acknowledges frames (OnAcknowledged), the
//   link rate, the delivered rates and the age of the shown data come from acknowledgements:
//   bytes acknowledged over the time the link was busy with them (a lower bound when the
//   stream leaves the link idle);
// - the link is spread over fps_target frames per second, or over the source's own frame rate
//   where the simulation makes fewer (OnSourceFrame): every frame it makes then gets the
//   detail the link allows at that rate;
// - the detail is a level on a ladder of fractions 2^(-level/4) (1, 0.84, 0.71, ... 1/4096):
//   subscribers at the same level share one encoder;
// - decrease at once (multiplicative) when the current level does not fit the measured link at
//   the target frame rate, or a delta frame was still being written when the next was ready;
// - increase one level at a time, only after the next level has fitted with 20% headroom for a
//   hold time (0.5 s, doubled up to 8 s each time an increase is followed by lateness): a dead
//   band between the two rules, so a steady link gives a steady level;
// - start small (a slow start, as TCP's): before the link is measured, the stream's first frame
//   is a keyframe of at most kFirstFrameBytes, and each frame delivered at the current level
//   doubles the particles of the next, until the link shows its rate (frames queue on it, a
//   frame outlasts its period, or frames are held back) and the rules above take over. A full-
//   detail first frame of 1 M particles (5.6 MB) needs 45 s on a 1 Mbit/s link.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>

namespace dysa::service {

// What a subscriber asks of its stream. With none set the detail stays whole (today's stream).
struct DetailBudget {
  double fps_target = 0;             // frames per wall second to hold, (0, 1000]; 0: none
  double bytes_per_second = 0;       // bytes per second at most, >= 1000; 0: no byte budget
  uint64_t particles_per_frame = 0;  // particles per frame at most, >= 1; 0: no budget
  bool active() const { return fps_target > 0 || bytes_per_second > 0 || particles_per_frame > 0; }
  // Throws std::invalid_argument naming the field and its range (a byte budget needs a frame
  // rate target, to be spread over frames).
  void Validate() const;
};

// What a stream delivers, as GetStatus reports it.
struct DetailStatus {
  double fraction = 1;           // of the particles sent (the detail chosen)
  uint32_t particles = 0;        // particles in the latest frame sent
  double bytes_per_second = 0;   // bytes delivered per second (write completions, EWMA ~1 s)
  double frames_per_second = 0;  // frames delivered per second (EWMA ~1 s)
  double age_s = 0;              // s, how old the latest delivered frame's data is; 0: none yet
  // Measured while sending; 0: not measured yet. With acknowledgements and a stream that never
  // fills the link, the best rate it has shown (a lower bound).
  double link_bytes_per_second = 0;
};

// One stream in GetStatus: its budget and what it delivers.
struct StreamReport {
  DetailBudget budget;
  DetailStatus status;
  uint64_t stream_id = 0;  // Subscription::id()
  bool view = false;       // it has a camera (FrameHub::SetStreamView)
};

// Seconds of the steady clock, the controller's clock in the server.
double SteadySeconds();

class DetailController {
 public:
  static constexpr int kLevels = 49;  // level 0: every particle, level 48: 1/4096
  // The slow start: the first frame's bytes at most (0.5 s at 1 Mbit/s, 5 ms at 100 Mbit/s),
  // and the levels each delivered frame moves up by (4: twice the particles).
  static constexpr double kFirstFrameBytes = 64 * 1024;
  static constexpr int kSlowStartStep = 4;
  static double LevelFraction(int level);

  explicit DetailController(DetailBudget budget);

  // A frame's first write starts at `now`: its size, its particles and the stream's particles
  // before selection, whether it is a keyframe, and when its data was produced (same clock).
  void OnFrameStart(double now, size_t bytes, uint32_t particles, uint32_t total, bool keyframe,
                    double produced);
  // A write of `bytes` completed at `now`; `frame_done`: it was the frame's last.
  void OnBytesDelivered(double now, size_t bytes, bool frame_done);
  // The source's frame `frame` (the simulation's frame number), produced at `produced`, is
  // about to start on this stream. The frame numbers give the source's frame rate whatever the
  // stream skips, and a source slower than fps_target caps the rate the link is spread over:
  // a simulation that makes 1.4 frames/s gets every frame at the detail 1.4 frames/s fit, not
  // the detail of fps_target (which left a 10 M stream at 9% of its particles on a link with room
  // for all of them).
  void OnSourceFrame(uint64_t frame, double produced);
  // Frames per second the source makes (0: not known yet), and the rate the detail is fitted to.
  double source_fps() const { return source_period_ > 0 ? 1 / source_period_ : 0; }
  double fitted_fps() const;
  // A new frame was ready at `now` while the current one was still being written.
  void OnLate(double now);
  // The client has received `frames` frames completely on this stream so far (its
  // acknowledgement, arriving at `now`); `rtt`: s, the client's latest acknowledgement round
  // trip (0: not known). From the first one on, delivery is measured from them. Stale or
  // repeated counts change nothing; a count above the frames started is capped.
  void OnAcknowledged(double now, uint64_t frames, double rtt = 0);
  // Whether to hold back the next frame at `now` (the stream then skips it, newest wins): with
  // acknowledgements, while two frames or more are on their way and the oldest went out more
  // than three frame periods and a round trip ago. The transport's buffers (megabytes) would
  // otherwise fill with frames the link cannot take, and every frame would arrive that much
  // older. A stream whose client stops reporting for 5 s falls back to write completions.
  bool Hold(double now);
  // The client will acknowledge (it sent an ack token): measure from acknowledgements from the
  // first frame on, so that the transport's buffers never fill with frames the link cannot take.
  void ExpectAcknowledgements() { acknowledged_ = true; }

  // The stream's particle count before selection, known before its first frame (a late joiner).
  void SetTotal(double now, uint32_t total);
  // The most particles a frame may hold (the hub's frame limit): the detail stays below it.
  void SetFrameLimit(uint64_t particles) { frame_limit_ = particles; }

  uint32_t total() const { return total_; }
  // Frames started on this stream, and acknowledged by its client (0: none, or no acks).
  uint64_t frames_started() const { return started_; }
  uint64_t frames_acknowledged() const { return acked_frames_; }
  int level() const { return level_; }
  // Whether the slow start is still on (the link not measured yet).
  bool slow_start() const { return slow_start_; }
  double fraction() const { return LevelFraction(level_); }
  // The codec's detail threshold for fraction() (0: every particle).
  uint32_t threshold() const;
  DetailStatus Status(double now) const;
  const DetailBudget& budget() const { return budget_; }

 private:
  void Decide(double now);
  // A frame sent at the current level arrived: the slow start doubles the next one's particles.
  void OnDeliveredAtLevel();
  void SampleLink(double now, double bytes_per_second);  // smoothed over ~1 s
  // Whether `level` fits the available bytes per second scaled by `share`.
  bool Fits(int level, double share) const;
  int BudgetLevel() const;  // the largest fraction the particle budget allows
  // The first level from `level` on whose frames fit the byte budget (no budget: `level`).
  int WithinByteBudget(int level) const;
  // The slow start's first level: a keyframe of at most kFirstFrameBytes.
  int FirstFrameLevel() const;
  double FrameBytes(int level, double bytes_per_particle) const;

  DetailBudget budget_;
  int level_ = 0;
  uint32_t total_ = 0;
  bool slow_start_ = true;  // cleared at once without a frame-rate target
  uint64_t frame_limit_ = UINT64_MAX;
  // Cost per particle, bytes: delta frames (what a stream mostly sends) and keyframes.
  double delta_bpp_ = 2.6, key_bpp_ = 5.6;
  std::optional<double> link_;  // bytes/s while sending
  double link_sampled_at_ = 0;
  // The frame being written.
  double frame_start_ = 0;
  size_t frame_bytes_ = 0;
  uint32_t frame_particles_ = 0;
  bool frame_keyframe_ = false;
  int frame_level_ = 0;
  double frame_produced_ = 0;
  // The source: the last frame number seen, when it was produced, and the smoothed period.
  std::optional<uint64_t> source_frame_;
  double source_produced_ = 0, source_period_ = 0;
  // Delivered rates: exponentially decayed sums (value / tau is the rate) at rates_at_.
  double bytes_sum_ = 0, frames_sum_ = 0, rates_at_ = 0;
  std::optional<double> shown_produced_;
  uint32_t shown_particles_ = 0;
  // Increase and decrease rules.
  std::optional<double> headroom_since_;
  double up_hold_ = 0.5;
  double last_increase_ = -1e9;
  double last_late_ = -1e9;
  bool late_blocked_ = false;  // lateness decreased already; wait for a frame at the new level
  // Delivery from acknowledgements: the frames started and not yet acknowledged (at most
  // kMaxUnacknowledged, the oldest dropped: a client that stops acknowledging costs nothing).
  struct Sent {
    uint64_t ordinal = 0;  // 1 for the stream's first frame
    size_t bytes = 0;
    uint32_t particles = 0;
    double start = 0, produced = 0;
    int level = 0;
  };
  static constexpr size_t kMaxUnacknowledged = 256;
  std::deque<Sent> sent_;
  uint64_t started_ = 0, acked_frames_ = 0;
  bool acknowledged_ = false;  // an acknowledgement came: write completions no longer measure
  double last_ack_ = -1e9;
  // The smallest round trip reported over ~10 s (queueing only adds to it), and since when.
  double rtt_min_ = 0, rtt_min_at_ = -1e9;
  // Acknowledged bytes and the link's busy time for them, exponentially decayed (~1 s).
  double acked_bytes_ = 0, acked_busy_ = 0;
  // The best rate a stream that leaves the link idle has shown (decayed ~1 s): what the status
  // reports while the link itself is not measured.
  double lower_bound_ = 0;
};

}  // namespace dysa::service
