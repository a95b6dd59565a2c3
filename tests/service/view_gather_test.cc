// A view stream's frames read only what they send (GatherSnapshot with the hub, issue 32): the
// selection where the particles live at a re-selection, the kept ids' particles in between, the
// next refinement while paused, and every particle's position extremes (the codec's range for a
// view keyframe) — and the bytes streamed are those of the full-read path (a snapshot of every
// particle, the view chosen on the host) for the same states, frame by frame.
// Built twice: view_gather_test on the CPU, and view_gather_gpu_test (DYSA_VIEW_GATHER_ON_CUDA,
// label gpu, skipping with the reason without a GPU) with the simulation on cuda:0, where the
// selection, the kept ids' gather and the bounds run on the device (cuda/view_subset.cu,
// cuda/view_reads.cu) and the full-read path reads every particle from the device.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <memory>
#include <vector>

#include "dysa/codec/frame_codec.h"
#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "dysa/service/frame_hub.h"
#include "dysa/service/frame_publisher.h"
#include "support/gpu_test.h"

namespace dysa::service {
namespace {

#ifdef DYSA_VIEW_GATHER_ON_CUDA
const Device kDevice = dysa::testing::kGpu;
#define SKIP_WITHOUT_DEVICE() SKIP_WITHOUT_GPU()
#else
const Device kDevice{};
#define SKIP_WITHOUT_DEVICE() \
  do {                        \
  } while (0)
#endif

class Listener : public FrameListener {
 public:
  void OnFrameReady() override {}
  void OnHubClosed() override {}
};

// seed_basic with 20^3 = 8000 particles.
Scene Scene8000() {
  Scene scene = LoadScene("seed_basic");
  SetParam(scene.params, "particle_quantity", 20);
  return scene;
}

// A look at the domain's middle from outside one corner, with a narrow field of view.
StreamView CornerView(const Simulation& sim) {
  const Aabb& d = sim.model().domain;
  StreamView v;
  for (int a = 0; a < 3; ++a) {
    const double size = d.max[a] - d.min[a];
    v.eye[a] = d.min[a] - 0.5 * size;
    v.target[a] = d.min[a] + 0.5 * size;
  }
  v.fov_y_deg = 25;
  return v;
}

// One view stream on a hub of its own; `full`: its snapshots read every particle (the path
// before view streams read only what they send), else GatherSnapshot with the hub.
struct Watcher {
  Watcher(const Simulation& sim, bool read_all, uint32_t stream_fields, int keyframe_interval)
      : full(read_all), fields(stream_fields) {
    hub.set_frame_needed([this] { needed = true; });
    SubscriptionOptions o;
    o.stream.fields = fields;
    o.stream.keyframe_interval = keyframe_interval;
    o.budget = {.particles_per_frame = 400};
    s = hub.Subscribe(o, &listener);
    hub.SetStreamView(s->id(), CornerView(sim));
  }
  // The frame a publish of the simulation's state gives (as the server does: a frame the hub
  // asks for again, the same state, when the first one could not be sent), or null.
  std::shared_ptr<const EncodedFrame> Publish(const Simulation& sim, bool force) {
    for (int tries = 0; tries < 3; ++tries) {
      needed = false;
      if (full) {
        GatherSnapshot(sim, fields, 0, snapshot);
      } else {
        GatherSnapshot(sim, hub, /*any_time=*/true, false, snapshot);
      }
      reads.push_back(snapshot.particles_read);
      hub.Publish(snapshot, force, false);
      if (auto frame = s->Take(nullptr)) return frame;
      if (!needed) return nullptr;
    }
    return nullptr;
  }

  const bool full;
  const uint32_t fields;
  FrameHub hub{4};
  Listener listener;
  std::shared_ptr<Subscription> s;
  FrameSnapshot snapshot;
  bool needed = false;
  std::vector<uint64_t> reads;  // particles read per gather
};

void ExpectSameFrame(const EncodedFrame& a, const EncodedFrame& b, int f) {
  EXPECT_EQ(a.keyframe, b.keyframe) << f;
  EXPECT_EQ(a.refines, b.refines) << f;
  EXPECT_EQ(a.partial, b.partial) << f;
  EXPECT_EQ(a.particles, b.particles) << f;
  EXPECT_EQ(a.chunks, b.chunks) << "frame " << f << ": the bytes differ";
}

TEST(ViewGather, RunningFramesReadOnlyTheSentParticlesAndStreamTheFullReadsBytes) {
  SKIP_WITHOUT_DEVICE();
  const uint32_t every = codec::kPositions | codec::kVelocity | codec::kSpeed | codec::kDensity;
  for (const uint32_t fields : {uint32_t(codec::kPositions), every}) {
    Simulation sim(Scene8000(), kDevice);
    const size_t n = sim.particle_count();
    Watcher full(sim, true, fields, 4), view(sim, false, fields, 4);
    int keyframes = 0;
    std::vector<uint64_t> reads;  // per frame, its last gather's
    for (int f = 0; f < 14; ++f) {
      if (f > 0) sim.StepFrame();
      const auto a = full.Publish(sim, false), b = view.Publish(sim, false);
      reads.push_back(view.reads.back());
      ASSERT_TRUE(a && b) << f;
      ExpectSameFrame(*a, *b, f);
      keyframes += b->keyframe;
      EXPECT_LE(b->particles, 400u);
      EXPECT_GT(b->particles, 300u);
    }
    EXPECT_GE(keyframes, 3) << "re-selections at keyframes (interval 4)";
    // Every full gather read every particle. A view frame reads what it sends: the selection at
    // a re-selection, the kept ids in between (published inline, the plan follows the gather, so
    // never both). Its first gather came before the hub had fitted the budget (every particle:
    // the read did not fit, the frame was read again).
    for (const uint64_t r : full.reads) EXPECT_EQ(r, n);
    for (size_t f = 1; f < reads.size(); ++f) EXPECT_LE(reads[f], 400u) << f << " of " << n;
  }
}

TEST(ViewGather, PausedRefinementsReadTheNextLevelAndCompleteTheFrameWithTheSameBytes) {
  SKIP_WITHOUT_DEVICE();
  Simulation sim(Scene8000(), kDevice);
  sim.StepFrame();
  sim.StepFrame();
  const size_t n = sim.particle_count();
  Watcher full(sim, true, codec::kPositions | codec::kSpeed, 60);
  Watcher view(sim, false, codec::kPositions | codec::kSpeed, 60);
  auto a = full.Publish(sim, true), b = view.Publish(sim, true);
  ASSERT_TRUE(a && b);
  ExpectSameFrame(*a, *b, 0);
  size_t sent = b->particles;
  int refinements = 0;
  while (b->partial) {
    ASSERT_LT(++refinements, 10);
    full.hub.BytesDelivered(full.s, SteadySeconds(), a->bytes, true);
    view.hub.BytesDelivered(view.s, SteadySeconds(), b->bytes, true);
    a = full.Publish(sim, true);
    b = view.Publish(sim, true);
    ASSERT_TRUE(a && b) << refinements;
    ExpectSameFrame(*a, *b, refinements);
    // A refinement reads its level's selection: the particles shown and the new ones.
    sent += b->particles;
    EXPECT_EQ(view.reads.back(), std::min(n, sent)) << refinements;
  }
  EXPECT_EQ(sent, n);
  EXPECT_GE(refinements, 4);
}

#ifndef DYSA_VIEW_GATHER_ON_CUDA  // the codec alone: no simulation
TEST(ViewGather, AViewKeyframeQuantisesOverEveryParticleGivenTheirBounds) {
  // Particles outside the domain widen the range: the bounds stand for the unsent ones.
  std::vector<float> p(3 * 1000);
  for (size_t i = 0; i < p.size(); ++i) p[i] = float(i % 97) / 50.0f - 0.5f;
  p[3] = -3, p[4] = 5, p[5] = 7;  // particle 1, not sent, holds the extremes
  std::vector<uint32_t> ids;
  for (uint32_t k = 0; k < 1000; k += 7) ids.push_back(k);
  codec::StreamConfig config;
  config.explicit_ids = true;
  config.fields = codec::kPositions;
  codec::FrameInput in;
  in.domain_min = {0, 0, 0};
  in.domain_max = {1, 1, 1};
  in.positions = p;
  in.ids = ids;
  const auto whole = codec::FrameEncoder(config).Encode(in);
  std::vector<float> sparse(p.size(), std::numeric_limits<float>::quiet_NaN());
  in.has_position_bounds = true;
  for (int a = 0; a < 3; ++a) {
    in.position_lo[a] = std::numeric_limits<float>::infinity();
    in.position_hi[a] = -std::numeric_limits<float>::infinity();
    for (size_t i = 0; i < 1000; ++i) {
      in.position_lo[a] = std::min(in.position_lo[a], p[3 * i + a]);
      in.position_hi[a] = std::max(in.position_hi[a], p[3 * i + a]);
    }
  }
  for (const uint32_t k : ids) std::copy_n(&p[3 * k], 3, &sparse[3 * k]);
  in.positions = sparse;
  EXPECT_EQ(codec::FrameEncoder(config).Encode(in), whole);
  in.has_position_bounds = false;  // the sent particles' extremes alone: another range
  EXPECT_NE(codec::FrameEncoder(config).Encode(in), whole);
}
#endif

}  // namespace
}  // namespace dysa::service
