#include "dysa/service/frame_hub.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#ifdef __GLIBC__
#include <malloc.h>
#endif

#include "view_stream.h"

namespace dysa::service {

using Clock = std::chrono::steady_clock;

namespace {

// Hands memory freed with a stream configuration back to the system. Its encoder's buffers (a few
// values per particle and field: 5 MB for 27,000 particles with every field) are allocated by the
// publishing thread and its OpenMP team, in glibc arenas of their own, where a few blocks still
// in use pin the free memory around them: without this, 64 configurations' buffers stayed in the
// process after their streams closed (issue 21, defect 7). A trim walks the free lists: a few
// milliseconds, once per configuration that goes.
void ReturnFreedMemory() {
#ifdef __GLIBC__
  malloc_trim(0);
#endif
}

// Frees `group` if its caller held the last reference (the Publish in progress, otherwise, does),
// then returns the memory.
void Release(std::shared_ptr<FrameGroup> group) {
  const std::weak_ptr<FrameGroup> weak = group;
  group.reset();
  if (weak.expired()) ReturnFreedMemory();
}

}  // namespace

// Subscribers with equal options share one encoder: one encoded sequence, decodable by each of
// them as long as they take every frame of it.
struct FrameGroup {
  explicit FrameGroup(const SubscriptionOptions& o) : options(o), encoder(o.stream) {}

  const SubscriptionOptions options;
  std::atomic<bool> keyframe_needed{true};
  // Bytes its encoder and latest frame hold, as the publishing thread last saw them.
  std::atomic<size_t> bytes{0};
  // Publishing thread only.
  codec::FrameEncoder encoder;
  uint64_t next_seq = 0;
  // When the frame-rate cap lets the next frame through (FrameHub::Publish).
  std::optional<Clock::time_point> next_due;
  // The earliest time a frame passes that cap (next_due less a quarter period of slack), in
  // steady-clock nanoseconds: the one rule both Publish and the simulation thread's GatherNeeds
  // apply (CapPasses); written with next_due.
  std::atomic<int64_t> passes_from_ns{std::numeric_limits<int64_t>::min()};
  void SetNextDue(std::optional<Clock::time_point> due, Clock::duration period) {
    next_due = due;
    passes_from_ns = due ? Nanoseconds(*due - period / 4) : std::numeric_limits<int64_t>::min();
  }
  // Whether a frame read at `t` passes the frame-rate cap (always without one).
  bool CapPasses(Clock::time_point t) const {
    return options.max_fps <= 0 || Nanoseconds(t) >= passes_from_ns;
  }
  static int64_t Nanoseconds(Clock::time_point t) {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()).count();
  }
  // The snapshot last encoded (frame, step, particles): a republish of it changes nothing.
  std::optional<std::array<uint64_t, 3>> last_snapshot;
  // A frame was left out since the last one encoded, every subscriber having one waiting
  // (FrameHub::LeftOutBehind): the first to take its frame asks for one (the simulation may
  // have paused on the frame left out).
  std::atomic<bool> owed{false};
  // Frames left out since the last one encoded, and the latest of them (its frame number).
  std::atomic<uint32_t> left_out{0};
  std::atomic<uint64_t> left_out_frame{FrameHub::kUnknownFrame};
  // Its subscriber's view, when options.view_owner is set (set at creation).
  std::shared_ptr<ViewStream> view;
  // Guarded by FrameHub::mu_.
  std::vector<std::shared_ptr<Subscription>> members;
};

bool SubscriptionOptions::operator==(const SubscriptionOptions& o) const {
  return stream == o.stream && max_fps == o.max_fps && view_owner == o.view_owner && solo == o.solo;
}

std::shared_ptr<const EncodedFrame> Subscription::Take(uint32_t* skipped) {
  std::shared_ptr<const EncodedFrame> frame;
  std::shared_ptr<FrameGroup> group;
  bool decodes = false;
  {
    std::lock_guard lock(frame_mu_);
    if (!pending_ || !group_) return nullptr;  // nothing new, or unsubscribed
    group = group_;
    frame = std::move(pending_);
    pending_.reset();
    const bool follows = last_seq_ && *last_seq_ + 1 == frame->seq;
    decodes = frame->keyframe || follows;
    if (decodes) {
      if (skipped) {
        *skipped = last_seq_ ? uint32_t(frame->seq - *last_seq_ - 1) + frame->left_out : 0;
      }
      last_seq_ = frame->seq;
    }
  }
  if (decodes) {
    // Read after the frame was taken (LeftOutBehind sets it before it looks).
    if (group->owed.exchange(false) && hub_->frame_needed_) hub_->frame_needed_();
    return frame;
  }
  // A delta frame after a gap: undecodable here. Wait for a keyframe.
  hub_->KeyframeFor(*this);
  return nullptr;
}

std::shared_ptr<Subscription> FrameHub::Subscribe(const SubscriptionOptions& requested,
                                                  FrameListener* listener) {
  requested.stream.Validate();
  requested.budget.Validate();
  SubscriptionOptions options = requested;
  if (!std::isfinite(options.max_fps) || options.max_fps < 0 || options.max_fps > 1000) {
    throw std::invalid_argument("max_fps: allowed range [0, 1000] frames per second");
  }
  auto subscription = std::make_shared<Subscription>();
  subscription->hub_ = this;
  subscription->listener_ = listener;
  subscription->detail_ = std::make_unique<DetailController>(options.budget);
  subscription->detail_->SetFrameLimit(max_frame_particles_);
  subscription->ack_token_ = options.ack_token;
  if (options.ack_token != 0) subscription->detail_->ExpectAcknowledgements();
  {
    std::lock_guard lock(mu_);
    if (options.ack_token != 0 &&
        std::any_of(subscriptions_.begin(), subscriptions_.end(),
                    [&](const auto& s) { return s->ack_token_ == options.ack_token; })) {
      throw std::invalid_argument("ack_token: another stream uses this token; pick a random one");
    }
    if (options.budget.active()) {
      // A late joiner starts at the detail its particle budget allows (the link is unknown).
      if (last_total_ > 0) subscription->detail_->SetTotal(SteadySeconds(), last_total_);
      options.stream.detail_threshold = subscription->detail_->threshold();
    }
    if (closed_) throw SubscriberLimitError("the server is shutting down");
    if (!options.budget.active()) {
      const std::string refusal = FrameLimitRefusal(last_total_, options.stream.stride);
      if (!refusal.empty()) throw SubscriberLimitError(refusal);
    }
    if (subscriptions_.size() >= max_subscribers_) {
      throw SubscriberLimitError("subscriber limit reached: at most " +
                                 std::to_string(max_subscribers_) +
                                 " streams at once (dysa-server --max-subscribers)");
    }
    auto it = std::find_if(groups_.begin(), groups_.end(),
                           [&](const auto& g) { return g->options == options; });
    if (it == groups_.end())
      it = groups_.insert(groups_.end(), std::make_shared<FrameGroup>(options));
    subscription->group_ = *it;
    subscription->id_ = next_id_++;
    (*it)->members.push_back(subscription);
    subscriptions_.push_back(subscription);
  }
  RequestKeyframe(*subscription->group_);
  return subscription;
}

FrameHub::~FrameHub() {
  std::vector<std::shared_ptr<Subscription>> left;
  {
    std::lock_guard lock(mu_);
    left = subscriptions_;
  }
  for (const auto& s : left) Unsubscribe(s);
}

void FrameHub::Unsubscribe(const std::shared_ptr<Subscription>& subscription) {
  {
    std::lock_guard lock(subscription->listener_mu_);
    subscription->listener_ = nullptr;
  }
  // The subscription object may outlive this (its stream holds it a little longer): it lets go
  // of its frame and its group now, and the group's buffers go with its last subscriber.
  std::shared_ptr<FrameGroup> group;
  {
    std::lock_guard lock(subscription->frame_mu_);
    group = std::move(subscription->group_);
    subscription->pending_.reset();
  }
  if (!group) return;  // unsubscribed before
  {
    std::lock_guard lock(mu_);
    std::erase(subscriptions_, subscription);
    std::erase(group->members, subscription);
    if (!group->members.empty()) return;
    std::erase(groups_, group);
  }
  Release(std::move(group));
}

void FrameHub::Close() {
  std::vector<std::shared_ptr<Subscription>> subscriptions;
  {
    std::lock_guard lock(mu_);
    closed_ = true;
    subscriptions = subscriptions_;
  }
  for (const auto& s : subscriptions) {
    std::lock_guard lock(s->listener_mu_);
    if (s->listener_) s->listener_->OnHubClosed();
  }
}

size_t FrameHub::subscribers() const {
  std::lock_guard lock(mu_);
  return subscriptions_.size();
}

size_t FrameHub::configurations() const {
  std::lock_guard lock(mu_);
  return groups_.size();
}

size_t FrameHub::configuration_bytes() const {
  std::lock_guard lock(mu_);
  size_t bytes = 0;
  for (const auto& g : groups_) bytes += g->bytes;
  return bytes;
}

uint32_t FrameHub::NeededFields() const {
  std::lock_guard lock(mu_);
  uint32_t fields = 0;
  for (const auto& g : groups_) fields |= g->options.stream.fields;
  return fields;
}

uint32_t FrameHub::NeededThreshold() const {
  std::lock_guard lock(mu_);
  uint32_t widest = 0;
  for (const auto& g : groups_) {
    const uint32_t t = g->options.stream.detail_threshold;
    // A view stream picks its particles by camera, and completes the frame while paused.
    if (t == 0 || g->options.view_owner != 0) return 0;
    widest = std::max(widest, t);
  }
  return widest;
}

FrameHub::Needs FrameHub::GatherNeeds(bool any_time, Clock::time_point now, uint64_t frame) const {
  std::lock_guard lock(mu_);
  Needs needs;
  for (const auto& g : groups_) {
    // Publish would skip this frame for a group under its frame-rate cap (a keyframe it needs
    // waits for the cap too): not read for it. A frame read for another group that turns due
    // meanwhile is a missed one for it, and the next frame is read.
    if (!any_time && (!g->CapPasses(now) || LeftOutBehind(*g, g->members, frame))) continue;
    const codec::StreamConfig& c = g->options.stream;
    needs.fields |= c.fields;
    if (g->view) {
      needs.views.push_back({g->view, c.fields, c.detail_threshold, c.stride, c.keyframe_interval});
      continue;
    }
    // The widest detail: 0 (every particle) wins.
    if (!needs.plain) {
      needs.plain_threshold = c.detail_threshold;
    } else if (needs.plain_threshold != 0) {
      needs.plain_threshold =
          c.detail_threshold == 0 ? 0 : std::max(needs.plain_threshold, c.detail_threshold);
    }
    needs.plain = true;
  }
  return needs;
}

std::string FrameHub::FrameLimitRefusal(uint64_t total, uint32_t stride) const {
  const uint64_t count = (total + std::max(stride, 1u) - 1) / std::max(stride, 1u);
  if (count <= max_frame_particles_) return "";
  return "StreamFrames: a full-detail frame of this scene holds " + std::to_string(count) +
         " particles; a frame holds at most " + std::to_string(max_frame_particles_) +
         ": ask for a budget (fps_target, particle_budget) or a stride of at least " +
         std::to_string((total + max_frame_particles_ - 1) / max_frame_particles_);
}

uint64_t FrameHub::frames_encoded() const {
  std::lock_guard lock(mu_);
  return frames_encoded_;
}

void FrameHub::KeyframeFor(Subscription& s) {
  std::shared_ptr<FrameGroup> old_group, group;
  {
    std::lock_guard lock(mu_);
    {
      std::lock_guard frame_lock(s.frame_mu_);
      group = s.group_;
    }
    if (!group) return;  // unsubscribed meanwhile
    if (group->members.size() > 1) {
      // The others keep up (or they would have left this frame out, LeftOutBehind): one
      // subscriber's gap would cost each of them a keyframe's bytes.
      const auto self = std::find_if(group->members.begin(), group->members.end(),
                                     [&](const auto& m) { return m.get() == &s; });
      if (self != group->members.end()) {
        const std::shared_ptr<Subscription> shared = *self;
        old_group = RegroupLocked(shared, [&](SubscriptionOptions& o) { o.solo = s.id_; });
      }
    }
  }
  if (old_group) {
    Release(std::move(old_group));  // RegroupLocked asked the new group for its keyframe
    return;
  }
  RequestKeyframe(*group);
}

void FrameHub::ApplyDetail(const std::shared_ptr<Subscription>& s, uint32_t threshold) {
  std::shared_ptr<FrameGroup> old_group;
  {
    std::lock_guard lock(mu_);
    old_group =
        RegroupLocked(s, [&](SubscriptionOptions& o) { o.stream.detail_threshold = threshold; });
  }
  if (old_group) Release(std::move(old_group));  // (a null one would trim the heap for nothing)
}

std::shared_ptr<FrameGroup> FrameHub::RegroupLocked(
    const std::shared_ptr<Subscription>& s,
    const std::function<void(SubscriptionOptions&)>& change) {
  std::shared_ptr<FrameGroup> old_group, new_group;
  {
    std::lock_guard frame_lock(s->frame_mu_);
    if (!s->group_ || closed_) return nullptr;
    SubscriptionOptions options = s->group_->options;
    change(options);
    if (options == s->group_->options) return nullptr;
    old_group = s->group_;
    auto it = std::find_if(groups_.begin(), groups_.end(),
                           [&](const auto& g) { return g->options == options; });
    if (it == groups_.end()) {
      it = groups_.insert(groups_.end(), std::make_shared<FrameGroup>(options));
      if (options.view_owner != 0) (*it)->view = s->view_;
    }
    new_group = *it;
    std::erase(old_group->members, s);
    if (old_group->members.empty()) std::erase(groups_, old_group);
    new_group->members.push_back(s);
    s->group_ = new_group;
    // The next frame comes from another encoder: only its keyframe decodes.
    s->pending_.reset();
    s->last_seq_.reset();
  }
  RequestKeyframe(*new_group);
  return old_group;
}

void FrameHub::SetStreamView(uint64_t stream_id, const StreamView& view) {
  view.Validate();
  std::shared_ptr<FrameGroup> old_group, group;
  {
    std::lock_guard lock(mu_);
    auto it = std::find_if(subscriptions_.begin(), subscriptions_.end(),
                           [&](const auto& s) { return s->id_ == stream_id; });
    if (it == subscriptions_.end()) {
      throw std::out_of_range("stream_id: no open stream " + std::to_string(stream_id) +
                              " (FrameMessage.stream_id of a StreamFrames call)");
    }
    const std::shared_ptr<Subscription>& s = *it;
    if (!s->view_) s->view_ = std::make_shared<ViewStream>();
    s->view_->SetView(view);
    old_group = RegroupLocked(s, [&](SubscriptionOptions& o) {
      o.view_owner = stream_id;
      o.stream.explicit_ids = true;  // the view picks the particles: their ids travel
    });
    std::lock_guard frame_lock(s->frame_mu_);
    group = s->group_;
  }
  // The new view's subset goes out now, also while paused: one keyframe request. A stream that
  // moved to its view's group has it from RegroupLocked; one already there (a new camera) asks
  // here. Asking twice sent the subset's keyframe twice whenever a publish came between the two
  // requests (it takes the first, the second asks again).
  const bool moved = old_group != nullptr;
  if (old_group) Release(std::move(old_group));  // (a null one would trim the heap for nothing)
  if (group && !moved) RequestKeyframe(*group);
}

void FrameHub::MaybeRefine(const std::shared_ptr<Subscription>& s) {
  std::shared_ptr<FrameGroup> group;
  {
    std::lock_guard lock(s->frame_mu_);
    // A frame still waiting is newer: it comes first (and a refinement then would replace it).
    if (!s->group_ || !s->group_->view || s->pending_) return;
    group = s->group_;
  }
  if (group->view->partial() && frame_needed_) frame_needed_();
}

bool FrameHub::LeftOutBehind(FrameGroup& group,
                             const std::vector<std::shared_ptr<Subscription>>& members,
                             uint64_t frame) {
  if (members.empty()) return false;
  // Owed before looking: a subscriber that takes its frame meanwhile either is seen free here or
  // finds the debt (Subscription::Take), never neither.
  group.owed = true;
  for (const auto& s : members) {
    std::lock_guard lock(s->frame_mu_);
    if (!s->pending_) return false;  // the frame is taken: encoded, which clears the debt
  }
  if (frame == kUnknownFrame || group.left_out_frame.exchange(frame) != frame) ++group.left_out;
  return true;
}

void FrameHub::RequestKeyframe(FrameGroup& group) {
  group.keyframe_needed = true;
  if (frame_needed_) frame_needed_();
}

void FrameHub::Publish(const FrameSnapshot& snapshot, bool force, bool discontinuity) {
  std::lock_guard publishing(publish_mu_);
  FitBudgetsTo(uint32_t(snapshot.positions.size() / 3));
  std::vector<std::pair<std::shared_ptr<FrameGroup>, std::vector<std::shared_ptr<Subscription>>>>
      work;
  {
    std::lock_guard lock(mu_);
    for (const auto& g : groups_) work.emplace_back(g, g->members);
  }
  // The frame-rate caps judge a frame by when it was read, as GatherNeeds did: were it judged
  // later, when this thread gets to it, a frame read just before its due time would be read for
  // nothing, or one read for another stream pass a cap a little early.
  const auto now = snapshot.read_at.value_or(Clock::now());
  const std::array<uint64_t, 3> this_snapshot = {snapshot.frame, snapshot.step,
                                                 snapshot.positions.size() / 3};
  const auto total = uint32_t(snapshot.positions.size() / 3);
  bool missed = false;
  for (auto& [group, members] : work) {
    // A group whose detail sends particles the snapshot did not gather (its detail rose since,
    // or it is a view stream, which may pick any particle) waits for the next frame, which
    // gathers them.
    // A view stream's own read is checked when it plans (ViewStream::Next).
    const uint32_t threshold = group->options.stream.detail_threshold;
    if (!group->view &&
        (!snapshot.plain_read ||
         (snapshot.threshold != 0 && (threshold == 0 || threshold > snapshot.threshold)))) {
      missed = true;
      continue;
    }
    if (group->view && !snapshot.complete && snapshot.view_reads.empty() &&
        snapshot.threshold != 0) {
      missed = true;  // a subset by rank only (GatherSnapshot without the hub): nothing to choose
      continue;
    }
    if (threshold == 0) {  // budgets chose a threshold below the limit in FitBudgetsTo
      const std::string refusal = FrameLimitRefusal(total, group->options.stream.stride);
      if (!refusal.empty()) {  // a scene that grew past the limit under a full-detail stream
        for (const auto& s : members) {
          std::lock_guard lock(s->listener_mu_);
          if (s->listener_) s->listener_->OnRefused(refusal);
        }
        continue;
      }
    }
    // A republish of the snapshot a group has (the server paused and a frame was asked for)
    // changes nothing for it unless it needs a keyframe; a view stream may refine it.
    const bool keyframe_needed = group->keyframe_needed.exchange(false);
    const bool fresh = keyframe_needed || discontinuity;
    const bool same = group->last_snapshot == this_snapshot;
    if (same && !fresh) {
      if (!group->view || members.empty()) continue;
      // A refinement must not replace a frame the subscriber has not taken yet.
      std::lock_guard lock(members.front()->frame_mu_);
      if (members.front()->pending_) continue;
    }
    // Its subscribers are all behind, each with a frame waiting: the next frame waits for them
    // (and its cap's due time stays), unless the frame must be seen (forced, or fresh: a
    // keyframe asked for, a discontinuity).
    if (!force && !fresh && LeftOutBehind(*group, members, snapshot.frame)) continue;
    // The frame-rate cap holds max_fps on average: the next frame is due one period after this
    // one was due (not after it was sent), and passes up to a quarter period early. Measuring
    // from the send instead skipped a frame whenever one came a hair early, so frames produced
    // at a multiple of the cap (50/s under a cap of 25) came at 2/3 of it, jitter deciding.
    const double max_fps = group->options.max_fps;
    const auto due_before = group->next_due;
    const auto period = std::chrono::duration_cast<Clock::duration>(
        std::chrono::duration<double>(max_fps > 0 ? 1.0 / max_fps : 0.0));
    if (max_fps > 0) {
      if (!force && !group->CapPasses(now)) {
        if (keyframe_needed) group->keyframe_needed = true;  // for the frame that passes
        continue;
      }
      // At most one period behind: no burst of frames after a pause or a slow spell.
      group->SetNextDue(group->next_due && now - *group->next_due < period
                            ? *group->next_due + period
                            : now + period,
                        period);
    }
    std::optional<ViewStream::Plan> plan;
    if (group->view) {
      plan =
          group->view->Next(snapshot, fresh, discontinuity, group->options.stream.detail_threshold,
                            group->options.stream.stride, group->options.stream.keyframe_interval);
      if (!plan) continue;  // the subscriber has the whole frame
      if (plan->missing) {
        // The snapshot was read for another plan: as if this frame had not come (its cap and
        // keyframe request stay for the frame read anew).
        group->SetNextDue(due_before, period);
        if (keyframe_needed || discontinuity) group->keyframe_needed = true;
        missed = true;
        continue;
      }
    }
    if (fresh) group->encoder.RequestKeyframe();
    group->last_snapshot = this_snapshot;
    group->owed = false;
    const uint32_t left_out = group->left_out.exchange(0);
    group->left_out_frame = kUnknownFrame;

    const uint32_t fields = group->options.stream.fields;
    codec::FrameInput input;
    input.step = snapshot.step;
    input.time = snapshot.time;
    input.domain_min = snapshot.domain_min;
    input.domain_max = snapshot.domain_max;
    input.positions = snapshot.positions;
    if (fields & (codec::kSpeed | codec::kVelocity)) input.velocities = snapshot.velocities;
    if (fields & codec::kDensity) input.densities = snapshot.densities;
    if (plan) input.ids = plan->ids;
    // Only the sent particles were read: the keyframe's range comes from every particle's
    // extremes, reduced where they live (the encoder would otherwise scan stale entries).
    if (plan && !snapshot.complete && snapshot.has_position_bounds) {
      input.has_position_bounds = true;
      input.position_lo = snapshot.position_lo;
      input.position_hi = snapshot.position_hi;
    }

    ++*frames_alive_;
    std::shared_ptr<EncodedFrame> encoded(new EncodedFrame,
                                          [alive = frames_alive_](EncodedFrame* frame) {
                                            --*alive;
                                            delete frame;
                                          });
    encoded->chunks = group->encoder.Encode(input);
    group->bytes = group->encoder.buffer_bytes();
    encoded->keyframe = group->encoder.last_was_keyframe();
    encoded->frame = snapshot.frame;
    encoded->seq = group->next_seq++;
    encoded->particles = group->encoder.last_count();
    encoded->total_particles = uint32_t(snapshot.positions.size() / 3);
    encoded->produced_unix_us = snapshot.produced_unix_us;
    encoded->left_out = left_out;
    if (plan) encoded->refines = plan->refines, encoded->partial = plan->partial;
    for (const codec::Chunk& c : encoded->chunks) encoded->bytes += c.size();
    if (transport_builder_) encoded->transport = transport_builder_(*encoded);
    {
      std::lock_guard lock(mu_);
      ++frames_encoded_;
    }
    for (const auto& s : members) {
      {
        std::lock_guard lock(s->frame_mu_);
        if (s->group_ != group) continue;  // unsubscribed or moved meanwhile
        s->pending_ = encoded;             // replaces an older frame not taken yet: latest wins
      }
      std::lock_guard lock(s->listener_mu_);
      if (s->listener_) s->listener_->OnFrameReady();
    }
  }
  if (missed && frame_needed_) frame_needed_();
  // A group whose last subscriber left during this Publish is freed here.
  for (auto& [group, members] : work) {
    members.clear();
    Release(std::move(group));
  }
}

}  // namespace dysa::service
