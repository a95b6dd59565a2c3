// Frame fan-out: each simulated frame is encoded once per distinct stream configuration and
// offered to every subscriber of that configuration, newest first.
//
// Each subscriber holds at most one frame waiting besides the one it is sending, so a slow or
// stalled reader skips frames and never slows the simulation or grows memory. A delta frame only
// decodes after the frame before it, so a subscriber that missed one (or just joined) waits for a
// keyframe and asks its group for one. A group whose every subscriber still has a frame waiting
// skips the next frames (neither read nor encoded) until one of them takes it: its next frame is
// then a delta after the waiting one. Replacing the waiting frame (newest wins) cost each such
// gap a keyframe, several times a delta's bytes, on exactly the links that were behind. A forced
// frame (a pause, a step, a reset) replaces it: the frame the subscribers see last is the state.
//
// Threads: Publish() runs on the simulation thread (it encodes, with OpenMP over chunks);
// Subscribe(), Unsubscribe() and Subscription::Take() run on RPC threads.
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "dysa/codec/frame_codec.h"
#include "dysa/service/detail_controller.h"
#include "dysa/service/view_detail.h"

namespace dysa::service {

struct ViewRead;  // view_stream.h
class ViewStream;

// One frame as subscribers see it: every array in particle-id order. Only the arrays some
// subscriber needs are filled (FrameHub::NeededFields()).
struct FrameSnapshot {
  uint64_t frame = 0;  // frames since the last reset
  uint64_t step = 0;
  double time = 0;                                   // s
  std::array<double, 3> domain_min{}, domain_max{};  // m
  std::vector<float> positions;                      // 3 per particle, m
  std::vector<float> velocities;                     // 3 per particle, m/s
  std::vector<float> densities;                      // kg/m^3
  int64_t produced_unix_us = 0;                      // wall clock, microseconds since the epoch
  // When GatherSnapshot read it (steady clock): the time the frame-rate caps judge it by, in
  // GatherNeeds and Publish alike (unset: when Publish gets it).
  std::optional<std::chrono::steady_clock::time_point> read_at;
  // The particles the arrays hold: those of DetailRank(id) below it (0: every one). The others'
  // entries are stale (GatherSnapshot copies only what the widest subscribed detail sends).
  uint32_t threshold = 0;
  // Whether the arrays hold every particle (a full read, or a snapshot made by hand): a view
  // stream may then choose its subset on the host. Otherwise only what `threshold` says (when
  // `plain_read`) and what `view_reads` list are valid.
  bool complete = true;
  bool plain_read = true;  // the streams without a camera had their read (`threshold`)
  // What was read for each view stream (view_stream.h) when the snapshot is not complete.
  std::vector<std::shared_ptr<const ViewRead>> view_reads;
  // Every particle's position extremes (Simulation::ReadPositionBounds), set when the snapshot
  // is not complete and a view stream is subscribed: its keyframes are quantised over them.
  bool has_position_bounds = false;
  std::array<float, 3> position_lo{}, position_hi{};
  // Particles the simulation handed to the host for this snapshot (each read counted: a
  // particle two view streams send counts twice). A full read counts every particle.
  uint64_t particles_read = 0;
};

// The most particles one frame holds (the codec's frame limit, kMaxCount): a stream that would
// send more is refused, and budgets never choose more.
inline constexpr uint64_t kMaxFrameParticles = 20'000'000;

struct EncodedFrame {
  uint64_t frame = 0;
  uint64_t seq = 0;  // position in its group's encoded sequence
  bool keyframe = false;
  std::vector<codec::Chunk> chunks;
  size_t bytes = 0;
  uint32_t particles = 0;        // in the frame (after stride and detail)
  uint32_t total_particles = 0;  // in the snapshot
  int64_t produced_unix_us = 0;
  // Frames its group left out just before it, every subscriber having had one waiting: missed
  // by whoever takes this frame after the one before it (Subscription::Take's `skipped`).
  uint32_t left_out = 0;
  // A view stream's progressive completion (FrameHub::SetStreamView): the frame adds its
  // particles to the one sent before (the same simulation frame); the frame shown, with what it
  // refines, still lacks particles (more follow while the simulation stays paused).
  bool refines = false;
  bool partial = false;
  // The frame in the transport's own form (the gRPC adapter's serialised messages), built once
  // per frame by the hub's transport builder and shared by every subscriber; null without one.
  std::shared_ptr<const void> transport;
};

struct SubscriptionOptions {
  codec::StreamConfig stream;
  double max_fps = 0;  // frames per wall second at most; 0: every frame
  // The subscriber's own budget: not part of the group's identity (subscribers with different
  // budgets at the same detail share an encoder). With one, the hub sets stream.detail_threshold.
  DetailBudget budget;
  // Nonzero: the id of the subscriber whose camera picks the particles (a group of its own).
  uint64_t view_owner = 0;
  // Nonzero: the client acknowledges the frames it receives under this token (Acknowledge), the
  // delivery signal of its DetailController. Unique among the streams; not part of the identity.
  uint64_t ack_token = 0;
  // Nonzero: the id of a subscriber that fell behind the others of its group and was given an
  // encoder of its own (a group of its own), so that its gap asks only itself for a keyframe.
  // Set by the hub, never by a client.
  uint64_t solo = 0;
  bool operator==(const SubscriptionOptions& other) const;
};

// Told by the hub that a subscriber has something new: a frame to take, or the end.
class FrameListener {
 public:
  virtual ~FrameListener() = default;
  virtual void OnFrameReady() = 0;
  // The hub is closing (server shutdown): end the stream.
  virtual void OnHubClosed() = 0;
  // A frame held back (FrameHub::HoldFrame) may go now: not a new frame, so not lateness.
  virtual void OnMayWrite() { OnFrameReady(); }
  // The stream cannot be sent (a full-detail frame over the frame limit): end it with `why`.
  virtual void OnRefused(const std::string& why) { (void)why; }
};

// Thrown by Subscribe when the subscriber limit is reached.
class SubscriberLimitError : public std::runtime_error {
  using std::runtime_error::runtime_error;
};

class FrameHub;
struct FrameGroup;

class Subscription {
 public:
  // The frame waiting for this subscriber when it can decode it, or nullptr when there is none
  // yet (OnFrameReady follows when one arrives). `skipped`: frames it missed since the one it
  // took before (EncodedFrame::left_out included).
  std::shared_ptr<const EncodedFrame> Take(uint32_t* skipped);
  // The stream's id (FrameMessage.stream_id, SetStreamView), unique within the hub, from 1.
  uint64_t id() const { return id_; }

 private:
  friend class FrameHub;
  FrameHub* hub_ = nullptr;
  uint64_t id_ = 0;
  std::shared_ptr<ViewStream> view_;  // set by SetStreamView (under FrameHub::mu_)

  std::mutex listener_mu_;  // held while the listener is called; Unsubscribe waits on it
  FrameListener* listener_ = nullptr;

  std::mutex frame_mu_;
  std::shared_ptr<FrameGroup> group_;  // null once unsubscribed
  std::shared_ptr<const EncodedFrame> pending_;
  std::optional<uint64_t> last_seq_;  // the last frame taken

  std::mutex detail_mu_;  // after FrameHub::mu_ and frame_mu_ when nested
  std::unique_ptr<DetailController> detail_;
  uint64_t ack_token_ = 0;  // set once, before the subscription is shared
};

class FrameHub {
 public:
  // `max_frame_particles`: the frame limit (kMaxFrameParticles; lower in tests).
  explicit FrameHub(size_t max_subscribers, uint64_t max_frame_particles = kMaxFrameParticles)
      : max_subscribers_(max_subscribers), max_frame_particles_(max_frame_particles) {}
  // Unsubscribes whoever has not: a subscription and its group hold each other until then.
  ~FrameHub();
  FrameHub(const FrameHub&) = delete;
  FrameHub& operator=(const FrameHub&) = delete;

  // Throws std::invalid_argument (bad options, naming the field) or SubscriberLimitError.
  // The subscriber's first frame is a keyframe; the hub asks for one (see set_frame_needed).
  std::shared_ptr<Subscription> Subscribe(const SubscriptionOptions& options,
                                          FrameListener* listener);
  // After it returns, the listener is never called again, and the subscription holds no frame
  // and takes none. Idempotent.
  void Unsubscribe(const std::shared_ptr<Subscription>& subscription);
  // Ends every stream (OnHubClosed) and refuses new subscribers.
  void Close();

  size_t subscribers() const;
  // Distinct stream configurations subscribed to: each holds an encoder. A configuration and
  // its buffers are freed when its last subscriber leaves (and the memory handed back).
  size_t configurations() const;
  // Bytes the configurations' encoders hold between frames.
  size_t configuration_bytes() const;
  // The codec fields some subscriber wants; 0 when no one subscribes (nothing to publish).
  uint32_t NeededFields() const;
  // The particles some subscriber's detail sends: those of DetailRank(id) below it; 0: every one
  // (a stream without a threshold). What GatherSnapshot copies.
  uint32_t NeededThreshold() const;
  // What a frame must read for the streams subscribed now (GatherSnapshot): the streams without
  // a camera (`plain`: some; their fields and the widest detail's threshold) and each view
  // stream's group (its ViewStream reads for it, ViewStream::Gather). Unless `any_time` (a
  // forced publish, a discontinuity), only for the streams that would take a frame now: one under
  // a frame-rate cap (max_fps, or an fps_target) that is not due at `now`, or whose subscribers
  // all have a frame waiting, is left out, so a simulation faster than its watchers does not read
  // the frames they would skip (`fields` 0: no stream takes this frame).
  struct ViewNeed {
    std::shared_ptr<ViewStream> view;
    uint32_t fields = 0, threshold = 0, stride = 1;
    int keyframe_interval = 1;
  };
  struct Needs {
    uint32_t fields = 0;  // every stream's
    bool plain = false;
    uint32_t plain_threshold = 0;
    std::vector<ViewNeed> views;
  };
  // `frame`: the simulation frame to be read (kUnknownFrame: each call counts as another frame
  // left out for a group behind).
  static constexpr uint64_t kUnknownFrame = UINT64_MAX;
  Needs GatherNeeds(bool any_time = true,
                    std::chrono::steady_clock::time_point now = std::chrono::steady_clock::now(),
                    uint64_t frame = kUnknownFrame) const;
  uint64_t frames_encoded() const;
  // Encoded frames alive (held by the hub, subscribers or writes in flight): at most two per
  // subscriber plus one per group, whatever the subscribers do.
  int64_t frames_alive() const { return *frames_alive_; }

  // What a subscriber's transport reports of its stream, `now` in SteadySeconds() (see
  // DetailController): the detail it then needs may move it to another group (a keyframe
  // follows). `frame` is the one whose writes start; `produced` its data's time on that clock.
  void FrameStarted(const std::shared_ptr<Subscription>& s, double now, const EncodedFrame& frame,
                    double produced);
  void BytesDelivered(const std::shared_ptr<Subscription>& s, double now, size_t bytes,
                      bool frame_done);
  void FrameLate(const std::shared_ptr<Subscription>& s, double now);
  // Whether the stream should hold back its next frame now (DetailController::Hold); its
  // listener hears OnFrameReady again when the next acknowledgement comes.
  bool HoldFrame(const std::shared_ptr<Subscription>& s, double now);
  // The client of the stream subscribed with `ack_token` has received `frames` frames of it
  // completely; `rtt`: s, its latest report's round trip (0: unknown). False when no stream has
  // that token (it ended, or never was).
  bool Acknowledge(uint64_t ack_token, double now, uint64_t frames, double rtt);
  // Each subscriber's budget and delivery, in subscription order.
  std::vector<StreamReport> StreamReports(double now) const;

  // Gives stream `stream_id` a camera: from its next frame on, its budget is spent on the
  // particles in view first, densest near the camera (view_detail.h), and while the simulation
  // is paused the rest of the shown frame follows in refining frames until it is complete
  // (EncodedFrame::refines). Without a budget the stream keeps sending every particle. Throws
  // std::invalid_argument (a bad view, naming the field and its range) or std::out_of_range (no
  // open stream has that id).
  void SetStreamView(uint64_t stream_id, const StreamView& view);

  // Encodes `snapshot` for every group that is due and offers it to the group's subscribers.
  // `force`: ignore frame-rate caps (a frame the user asked for: a step, a step back, a reset).
  // `discontinuity`: the frame does not follow the previous one (back, reset, new scene).
  // Calls are serialised (each group's encoder follows one sequence).
  void Publish(const FrameSnapshot& snapshot, bool force, bool discontinuity);

  // Called (from any thread) when a subscriber needs a frame published although the simulation
  // may be paused: a late joiner or a subscriber waiting for a keyframe.
  void set_frame_needed(std::function<void()> callback) { frame_needed_ = std::move(callback); }
  // Builds EncodedFrame::transport for each encoded frame (on the publishing thread). Set before
  // anything is published.
  using TransportBuilder = std::function<std::shared_ptr<const void>(const EncodedFrame&)>;
  void set_transport_builder(TransportBuilder builder) { transport_builder_ = std::move(builder); }

 private:
  friend class Subscription;
  void RequestKeyframe(FrameGroup& group);
  // Whether every one of `members` (of `group`) still has a frame it has not taken (none:
  // false): simulation frame `frame` is then left out for the group (counted once however often
  // it is asked), which owes its subscribers one.
  static bool LeftOutBehind(FrameGroup& group,
                            const std::vector<std::shared_ptr<Subscription>>& members,
                            uint64_t frame);
  // `s` took a frame it cannot decode (it missed the one before): it needs a keyframe. Where
  // others share its group, it moves to a group of its own (SubscriptionOptions::solo) and only
  // that group's next frame is a keyframe; alone, its group's next frame is.
  void KeyframeFor(Subscription& s);
  // Moves `s` to the group of its options with this detail threshold (after a detail_mu_ scope).
  void ApplyDetail(const std::shared_ptr<Subscription>& s, uint32_t threshold);
  // Moves `s` to the group of its options changed by `change` (creating it); mu_ held. Returns
  // the group it left (to Release after the lock), or null when the options did not change.
  std::shared_ptr<FrameGroup> RegroupLocked(
      const std::shared_ptr<Subscription>& s,
      const std::function<void(SubscriptionOptions&)>& change);
  // A view stream finished sending a frame: asks for the next refinement when it lacks some.
  void MaybeRefine(const std::shared_ptr<Subscription>& s);
  uint64_t next_id_ = 1;  // guarded by mu_
  // Sets every budgeted subscriber's particle count (Publish, before encoding).
  void FitBudgetsTo(uint32_t total);
  uint32_t last_total_ = 0;  // particles of the latest snapshot published (guarded by mu_)

  // A full-detail stream's message when a frame of `total` particles is over the frame limit;
  // empty when it fits.
  std::string FrameLimitRefusal(uint64_t total, uint32_t stride) const;

  const size_t max_subscribers_;
  const uint64_t max_frame_particles_;
  std::function<void()> frame_needed_;
  TransportBuilder transport_builder_;
  std::mutex publish_mu_;  // one Publish at a time
  mutable std::mutex mu_;
  bool closed_ = false;
  std::vector<std::shared_ptr<FrameGroup>> groups_;
  std::vector<std::shared_ptr<Subscription>> subscriptions_;
  uint64_t frames_encoded_ = 0;
  // Shared with each frame's deleter, which may run after the hub is gone.
  std::shared_ptr<std::atomic<int64_t>> frames_alive_ = std::make_shared<std::atomic<int64_t>>(0);
};

}  // namespace dysa::service
