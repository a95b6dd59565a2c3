// View-dependent detail (view_detail.h): the particles in view first and denser near the camera,
// exactly the budget, nested and stable subsets, range errors for bad cameras; and through the
// FrameHub, the progressive completion of a republished frame, which assembles bit-exactly into
// the full-detail frame within a bounded number of frames; and setting a camera sends the view's
// subset once (one keyframe request), then only refinements, also with a publishing thread that
// answers each request as a paused server does.
#include "dysa/service/view_detail.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <functional>
#include <mutex>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "dysa/codec/frame_merge.h"
#include "dysa/service/frame_hub.h"

namespace dysa::service {
namespace {

// n particles uniformly at random in [-1, 1]^3, in id order.
std::vector<float> Cloud(size_t n, uint32_t seed = 7) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1, 1);
  std::vector<float> p(3 * n);
  for (float& x : p) x = u(rng);
  return p;
}

// Looks along +x at the box from x = -3 with a narrow field: the middle of the box is in view.
StreamView NarrowView() {
  StreamView v;
  v.eye = {-3, 0, 0};
  v.target = {0, 0, 0};
  v.fov_y_deg = 20;
  v.aspect = 1;
  return v;
}

const std::array<double, 3> kLo = {-1, -1, -1}, kHi = {1, 1, 1};

TEST(ViewDetail, InViewParticlesComeFirstDenserNearTheCameraWithinTheBudget) {
  const size_t n = 40000;
  const std::vector<float> p = Cloud(n);
  const ViewOrder order(NarrowView(), p, kLo, kHi, 1);
  ASSERT_EQ(order.candidates(), n);
  const std::vector<uint32_t> kept = order.Select(4000);
  EXPECT_EQ(kept.size(), 4000u);  // exactly the budget
  EXPECT_TRUE(std::is_sorted(kept.begin(), kept.end()));

  size_t in_view_all = 0;
  for (uint32_t id = 0; id < n; ++id) in_view_all += order.InView(id);
  size_t in_view = 0, near = 0, far = 0, near_all = 0, far_all = 0;
  for (uint32_t id : kept) in_view += order.InView(id);
  for (uint32_t id = 0; id < n; ++id) {
    if (!order.InView(id)) continue;
    (p[3 * id] < 0 ? near_all : far_all) += 1;
  }
  for (uint32_t id : kept) {
    if (order.InView(id)) (p[3 * id] < 0 ? near : far) += 1;
  }
  const double share_all = double(in_view_all) / n, share = double(in_view) / kept.size();
  EXPECT_GT(share_all, 0.1);
  EXPECT_LT(share_all, 0.6);
  EXPECT_GT(share, 0.75) << "in view: " << share_all << " of all, " << share << " of the kept";
  EXPECT_GT(share, 2 * share_all);
  EXPECT_GT(kept.size() - in_view, 0u) << "particles out of view keep a coarse share";
  // The near half (x < 0, 2-3 m away) keeps a larger fraction than the far half (3-4 m).
  const double near_fraction = double(near) / near_all, far_fraction = double(far) / far_all;
  EXPECT_GT(near_fraction, 1.3 * far_fraction) << near_fraction << " vs " << far_fraction;
}

TEST(ViewDetail, SubsetsNestAcrossBudgetsAndStayStableAcrossFrames) {
  const size_t n = 20000;
  std::vector<float> p = Cloud(n, 3);
  const ViewOrder order(NarrowView(), p, kLo, kHi, 2);
  EXPECT_EQ(order.candidates(), n / 2);
  const std::vector<uint32_t> small = order.Select(500), mid = order.Select(2500);
  const std::vector<uint32_t> all = order.Select(1u << 30);
  EXPECT_TRUE(std::includes(mid.begin(), mid.end(), small.begin(), small.end()));
  ASSERT_EQ(all.size(), n / 2);
  for (uint32_t id : all) EXPECT_EQ(id % 2, 0u);
  EXPECT_EQ(ViewOrder(NarrowView(), p, kLo, kHi, 2).Select(2500), mid) << "deterministic";

  // The fluid moves a little: few particles change cell, so the subset barely changes.
  for (size_t i = 0; i < p.size(); ++i) p[i] += 1e-3f * std::sin(float(i));
  const std::vector<uint32_t> moved = ViewOrder(NarrowView(), p, kLo, kHi, 2).Select(2500);
  std::vector<uint32_t> common;
  std::set_intersection(mid.begin(), mid.end(), moved.begin(), moved.end(),
                        std::back_inserter(common));
  EXPECT_GT(common.size(), 0.95 * mid.size());
}

TEST(ViewDetail, BadCamerasAreRefusedNamingTheFieldAndItsRange) {
  const auto message = [](StreamView v) -> std::string {
    try {
      v.Validate();
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "accepted";
  };
  StreamView v = NarrowView();
  EXPECT_EQ(message(v), "accepted");
  v.fov_y_deg = 0.5;
  EXPECT_EQ(message(v), "fov_y_deg: allowed range [1, 179] degrees");
  v = NarrowView();
  v.aspect = 100;
  EXPECT_EQ(message(v), "aspect: allowed range [0.05, 20] (width / height)");
  v = NarrowView();
  v.target = v.eye;
  EXPECT_EQ(message(v), "target: at least 1e-6 m from eye (the view direction)");
  v = NarrowView();
  v.up = {1, 0, 0};  // along the view direction
  EXPECT_EQ(message(v), "up: nonzero and not parallel to target - eye");
  v = NarrowView();
  v.eye[1] = NAN;
  EXPECT_EQ(message(v), "eye: each component finite, in [-1e6, 1e6] m");
}

class Listener : public FrameListener {
 public:
  void OnFrameReady() override {}
  void OnHubClosed() override {}
};

FrameSnapshot Snapshot(uint64_t frame, const std::vector<float>& positions) {
  FrameSnapshot s;
  s.frame = frame;
  s.step = 10 * frame;
  s.domain_min = kLo;
  s.domain_max = kHi;
  s.positions = positions;
  s.velocities.assign(positions.size(), 0.25f);
  return s;
}

TEST(ViewDetail, AViewStreamKeepsItsSubsetAcrossFramesSoDeltaCodingPays) {
  FrameHub hub(4);
  Listener l;
  SubscriptionOptions o;
  o.budget = {.particles_per_frame = 800};
  auto s = hub.Subscribe(o, &l);
  hub.SetStreamView(s->id(), NarrowView());
  std::vector<float> p = Cloud(8000);
  codec::FrameDecoder decoder;
  std::vector<uint32_t> first_ids;
  for (uint64_t f = 1; f <= 4; ++f) {
    for (float& x : p) x *= 0.9999f;  // the fluid moves a little
    hub.Publish(Snapshot(f, p), false, false);
    auto frame = s->Take(nullptr);
    ASSERT_TRUE(frame) << f;
    EXPECT_EQ(frame->keyframe, f == 1) << f;
    EXPECT_FALSE(frame->refines);
    EXPECT_TRUE(frame->partial);
    EXPECT_LE(frame->particles, 800u);
    auto decoded = decoder.AddChunks(frame->chunks);
    ASSERT_TRUE(decoded) << f;
    EXPECT_TRUE(decoded->explicit_ids);
    if (f == 1) first_ids = decoded->ids;
    EXPECT_EQ(decoded->ids, first_ids) << "the same particles while the view holds";
  }
  // The subscriber misses a frame (a forced one replaced the one it had waiting): it gets a
  // keyframe, of the same particles.
  hub.Publish(Snapshot(5, p), false, false);
  hub.Publish(Snapshot(6, p), /*force=*/true, false);
  EXPECT_FALSE(s->Take(nullptr)) << "a delta frame after a gap waits for a keyframe";
  hub.Publish(Snapshot(7, p), false, false);
  auto frame = s->Take(nullptr);
  ASSERT_TRUE(frame);
  EXPECT_TRUE(frame->keyframe);
  auto decoded = codec::FrameDecoder().AddChunks(frame->chunks);
  ASSERT_TRUE(decoded);
  EXPECT_EQ(decoded->ids, first_ids);
}

TEST(ViewDetail, RepublishedFramesCompleteTheShownFrameBitExactly) {
  FrameHub hub(4);
  std::atomic<int> needed{0};
  hub.set_frame_needed([&] { ++needed; });
  Listener l, plain_listener;
  SubscriptionOptions o;
  o.budget = {.particles_per_frame = 500};
  auto s = hub.Subscribe(o, &l);
  auto plain = hub.Subscribe({}, &plain_listener);
  hub.SetStreamView(s->id(), NarrowView());
  EXPECT_THROW(hub.SetStreamView(s->id() + 100, NarrowView()), std::out_of_range);
  StreamView bad = NarrowView();
  bad.aspect = 0;
  EXPECT_THROW(hub.SetStreamView(s->id(), bad), std::invalid_argument);

  const size_t n = 8000;
  const FrameSnapshot snapshot = Snapshot(3, Cloud(n));
  hub.Publish(snapshot, true, false);
  ASSERT_TRUE(plain->Take(nullptr));
  codec::FrameDecoder decoder;
  auto frame = s->Take(nullptr);
  ASSERT_TRUE(frame);
  EXPECT_FALSE(frame->refines);
  ASSERT_TRUE(frame->partial);
  auto shown = decoder.AddChunks(frame->chunks);
  ASSERT_TRUE(shown);
  const uint32_t budget = shown->count;
  EXPECT_LE(budget, 500u);

  // The frame is delivered: the hub asks for another publish, which refines it. Each refinement
  // doubles the particles selected, so log2(n / budget) of them complete the frame.
  int refinements = 0;
  while (frame->partial) {
    const int before = needed;
    hub.BytesDelivered(s, SteadySeconds(), frame->bytes, true);
    ASSERT_EQ(needed, before + 1) << "a partial frame asks for its refinement";
    hub.Publish(snapshot, true, false);
    EXPECT_FALSE(plain->Take(nullptr)) << "the same frame again is nothing new to a plain stream";
    frame = s->Take(nullptr);
    ASSERT_TRUE(frame);
    EXPECT_TRUE(frame->refines);
    auto more = decoder.AddChunks(frame->chunks);
    ASSERT_TRUE(more);
    codec::MergeRefinement(*shown, *more);
    ++refinements;
    ASSERT_LE(refinements, int(std::ceil(std::log2(double(n) / budget))) + 1);
  }
  const int before = needed;
  hub.BytesDelivered(s, SteadySeconds(), frame->bytes, true);
  EXPECT_EQ(needed, before) << "a complete frame asks for nothing";
  hub.Publish(snapshot, true, false);
  EXPECT_FALSE(s->Take(nullptr)) << "nothing more to send of a complete frame";

  // The full-detail frame as a stream without a budget gets it.
  codec::FrameInput in;
  in.domain_min = snapshot.domain_min;
  in.domain_max = snapshot.domain_max;
  in.positions = snapshot.positions;
  in.velocities = snapshot.velocities;
  auto full = codec::FrameDecoder().AddChunks(codec::FrameEncoder({}).Encode(in));
  ASSERT_TRUE(full);
  ASSERT_EQ(shown->count, n);
  for (uint32_t k = 0; k < n; ++k) ASSERT_EQ(shown->ids[k], k);
  EXPECT_EQ(std::memcmp(shown->positions.data(), full->positions.data(), 12 * n), 0);
}

TEST(ViewDetail, SettingACameraAsksForOneKeyframe) {
  FrameHub hub(4);
  std::atomic<int> needed{0};
  hub.set_frame_needed([&] { ++needed; });
  Listener l;
  SubscriptionOptions o;
  o.budget = {.particles_per_frame = 500};
  auto s = hub.Subscribe(o, &l);
  const FrameSnapshot snapshot = Snapshot(3, Cloud(4000));
  hub.Publish(snapshot, true, false);
  ASSERT_TRUE(s->Take(nullptr));
  // The first camera moves the stream to a view group of its own: one request, not one for the
  // move and another for the view (a publish between the two sent the subset's keyframe twice).
  int before = needed;
  hub.SetStreamView(s->id(), NarrowView());
  EXPECT_EQ(needed, before + 1) << "one keyframe request for the first camera";
  // A new camera on the same group: one request too.
  StreamView v = NarrowView();
  v.eye = {-3, 0.5, 0};
  before = needed;
  hub.SetStreamView(s->id(), v);
  EXPECT_EQ(needed, before + 1) << "one keyframe request for a new camera";
  // Each is answered by one keyframe of the view's subset.
  hub.Publish(snapshot, true, false);
  auto frame = s->Take(nullptr);
  ASSERT_TRUE(frame);
  EXPECT_TRUE(frame->keyframe);
  EXPECT_FALSE(frame->refines);
}

// A paused server: each frame request (set_frame_needed) republishes the shown frame on a thread
// of its own, as SimulationHost does (requests that come together are one publish). After each
// publish the subscriber takes its frame and reports it delivered, which asks for the next
// refinement; `frames` records what it took.
class PausedServer {
 public:
  struct Taken {
    bool keyframe, refines, partial;
  };
  PausedServer(FrameHub& hub, FrameSnapshot snapshot)
      : hub_(hub), snapshot_(std::move(snapshot)), thread_([this] { Loop(); }) {}
  ~PausedServer() {
    {
      std::lock_guard lock(mu_);
      stop_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  void Request() {
    {
      std::lock_guard lock(mu_);
      requested_ = true;
    }
    cv_.notify_all();
  }
  void Watch(std::shared_ptr<Subscription> s) {
    std::lock_guard lock(mu_);
    watched_ = std::move(s);
  }
  // Waits until `done(frames)` holds (5 s at most); the frames taken so far.
  std::vector<Taken> WaitFor(const std::function<bool(const std::vector<Taken>&)>& done) {
    std::unique_lock lock(mu_);
    cv_.wait_for(lock, std::chrono::seconds(5), [&] { return done(frames_); });
    return frames_;
  }

 private:
  void Loop() {
    for (;;) {
      std::shared_ptr<Subscription> s;
      {
        std::unique_lock lock(mu_);
        cv_.wait(lock, [&] { return stop_ || requested_; });
        if (stop_) return;
        requested_ = false;
        s = watched_;
      }
      hub_.Publish(snapshot_, true, false);
      if (!s) continue;
      auto frame = s->Take(nullptr);
      if (!frame) continue;
      {
        std::lock_guard lock(mu_);
        frames_.push_back({frame->keyframe, frame->refines, frame->partial});
      }
      cv_.notify_all();
      hub_.BytesDelivered(s, SteadySeconds(), frame->bytes, true);
    }
  }

  FrameHub& hub_;
  const FrameSnapshot snapshot_;
  std::mutex mu_;
  std::condition_variable cv_;
  bool stop_ = false, requested_ = false;
  std::shared_ptr<Subscription> watched_;
  std::vector<Taken> frames_;
  std::thread thread_;
};

TEST(ViewDetail, SettingACameraWhilePausedSendsTheSubsetOnceThenOnlyRefinements) {
  // The repeat needed a publish to come between two keyframe requests: a few rounds, each a
  // fresh hub, stream and camera.
  for (int round = 0; round < 10; ++round) {
    FrameHub hub(4);
    PausedServer server(hub, Snapshot(3, Cloud(4000, 7 + round)));
    hub.set_frame_needed([&] { server.Request(); });
    Listener l;
    SubscriptionOptions o;
    o.budget = {.particles_per_frame = 500};
    auto s = hub.Subscribe(o, &l);
    server.Watch(s);
    server.Request();
    using Taken = PausedServer::Taken;
    ASSERT_EQ(server.WaitFor([](const std::vector<Taken>& f) { return !f.empty(); }).size(), 1u)
        << "the stream's first frame";
    hub.SetStreamView(s->id(), NarrowView());
    // The view's frames: its subset (partial), then refinements until the frame is complete.
    const std::vector<Taken> frames = server.WaitFor([](const std::vector<Taken>& f) {
      return f.size() > 1 && !f.back().partial && f.back().refines;
    });
    ASSERT_GE(frames.size(), 3u) << "round " << round;
    EXPECT_TRUE(frames[0].keyframe && !frames[0].partial) << "the plain stream's frame";
    EXPECT_TRUE(frames[1].keyframe && frames[1].partial && !frames[1].refines)
        << "round " << round << ": the view's subset";
    for (size_t k = 2; k < frames.size(); ++k) {
      EXPECT_TRUE(frames[k].refines) << "round " << round << ", frame " << k
                                     << ": only refinements after the subset, not the subset again";
    }
    ASSERT_FALSE(frames.back().partial) << "round " << round << ": the frame completes";
    server.Watch(nullptr);
    hub.Unsubscribe(s);
  }
}

}  // namespace
}  // namespace dysa::service
