#include "dysa/service/frame_publisher.h"

#include <omp.h>

#include <chrono>
#include <cstdint>
#include <memory>
#include <utility>

#include "view_stream.h"

namespace dysa::service {

namespace {

double MillisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

int64_t UnixMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace

namespace {

// The frame's header fields, and the arrays `fields` needs sized for every id (resizing keeps
// what is there: nothing is written that is not sent).
void PrepareSnapshot(const Simulation& sim, uint32_t fields, FrameSnapshot& s) {
  const size_t n = sim.particle_count();
  s.frame = sim.frame();
  s.step = sim.step();
  s.time = sim.time();
  const Aabb& domain = sim.model().domain;
  for (int a = 0; a < 3; ++a) {
    s.domain_min[a] = domain.min[a];
    s.domain_max[a] = domain.max[a];
  }
  s.produced_unix_us = UnixMicros();
  s.read_at.reset();
  // Storage order is cell order and changes every step; subscribers index by id. Only the fields
  // asked for are read, in id order.
  const bool velocities = fields & (codec::kSpeed | codec::kVelocity);
  const bool densities = fields & codec::kDensity;
  s.positions.resize(3 * n);
  s.velocities.resize(velocities ? 3 * n : 0);
  s.densities.resize(densities ? n : 0);
  s.complete = true;
  s.plain_read = true;
  s.view_reads.clear();
  s.has_position_bounds = false;
  s.particles_read = 0;
}

// The snapshot's arrays that `fields` (one stream's) needs.
Simulation::ParticlesById ArraysFor(uint32_t fields, FrameSnapshot& s) {
  Simulation::ParticlesById out{s.positions, {}, {}};
  if (fields & (codec::kSpeed | codec::kVelocity)) out.velocity = s.velocities;
  if (fields & codec::kDensity) out.density = s.densities;
  return out;
}

}  // namespace

void GatherSnapshot(const Simulation& sim, uint32_t fields, uint32_t threshold, FrameSnapshot& s) {
  PrepareSnapshot(sim, fields, s);
  // When every subscriber sends a subset by rank, only those particles are read: on the CPU a
  // scan of the solver's arrays (the rank is a hash of the id, the copy is what costs), on a GPU
  // chosen and packed there, so only they cross to the host. The cost then scales with the
  // particles sent, so a scene far above the frame limit can be watched with a budget.
  s.threshold = threshold;
  s.complete = threshold == 0;
  s.particles_read =
      sim.ReadParticlesByIdBelowRank(threshold, {s.positions, s.velocities, s.densities});
}

bool GatherSnapshot(const Simulation& sim, const FrameHub& hub, bool any_time, bool discontinuity,
                    FrameSnapshot& s) {
  const auto now = std::chrono::steady_clock::now();
  const FrameHub::Needs needs = hub.GatherNeeds(any_time || discontinuity, now, sim.frame());
  if (needs.fields == 0) return false;
  // A stream of every particle reads them all anyway: the view streams then choose from them on
  // the host, as before (the same ids, ViewKeys either way). On a GPU too, each view stream
  // reads only what it sends: the selection, the kept ids' gather and the bounds all run on the
  // device (Simulation::ReadViewSubset, ReadParticlesByIds, ReadPositionBounds).
  if (needs.views.empty() || (needs.plain && needs.plain_threshold == 0)) {
    GatherSnapshot(sim, needs.fields, needs.plain_threshold, s);
    s.read_at = now;
    return true;
  }
  PrepareSnapshot(sim, needs.fields, s);
  s.read_at = now;
  s.complete = false;
  s.plain_read = needs.plain;
  s.threshold = needs.plain_threshold;
  if (needs.plain) {
    s.particles_read += sim.ReadParticlesByIdBelowRank(needs.plain_threshold,
                                                       {s.positions, s.velocities, s.densities});
  }
  // Each view stream reads what it sends (view_stream.h): a selection where the particles live,
  // or the ids it keeps; never every particle.
  for (const FrameHub::ViewNeed& v : needs.views) {
    ViewRead r = v.view->Gather(sim, s, discontinuity, v.threshold, v.stride, v.keyframe_interval,
                                ArraysFor(v.fields, s));
    s.particles_read += r.particles_read;
    s.view_reads.push_back(std::make_shared<const ViewRead>(std::move(r)));
  }
  // A view keyframe's positions are quantised over every particle's extremes (codec): 24 bytes,
  // reduced where the particles live, instead of every position.
  const Simulation::PositionBounds bounds = sim.ReadPositionBounds();
  s.has_position_bounds = true;
  s.position_lo = bounds.lo;
  s.position_hi = bounds.hi;
  return true;
}

FramePublisher::FramePublisher(FrameHub& hub, int threads) : hub_(hub) {
  if (threads > 0) thread_ = std::thread([this, threads] { Loop(threads); });
}

FramePublisher::~FramePublisher() { Stop(); }

void FramePublisher::Stop() {
  {
    std::lock_guard lock(mu_);
    stop_ = true;
  }
  offered_.notify_one();
  published_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void FramePublisher::Offer(FrameSnapshot& snapshot, bool force, bool discontinuity) {
  std::unique_lock lock(mu_);
  if (stop_) return;
  const uint64_t number = ++offered_count_;
  if (!thread_.joinable()) {  // inline
    lock.unlock();
    const auto start = std::chrono::steady_clock::now();
    hub_.Publish(snapshot, force, discontinuity);
    const double ms = MillisecondsSince(start);
    lock.lock();
    timing_.Add(ms);
    published_count_ = number;
    return;
  }
  std::swap(waiting_, snapshot);
  if (!has_waiting_) force_ = discontinuity_ = false;
  has_waiting_ = true;
  force_ |= force;
  discontinuity_ |= discontinuity;
  offered_.notify_one();
  if (force) published_.wait(lock, [&] { return stop_ || published_count_ >= number; });
}

StageTiming FramePublisher::timing() const {
  std::lock_guard lock(mu_);
  return timing_;
}

void FramePublisher::ResetTiming() {
  std::lock_guard lock(mu_);
  timing_ = {};
}

void FramePublisher::Loop(int threads) {
  // The OpenMP thread count is per native thread: this one's is set here.
  omp_set_num_threads(threads);
  FrameSnapshot frame;
  while (true) {
    bool force = false, discontinuity = false;
    uint64_t number = 0;
    {
      std::unique_lock lock(mu_);
      offered_.wait(lock, [&] { return stop_ || has_waiting_; });
      if (stop_) return;
      std::swap(frame, waiting_);
      has_waiting_ = false;
      force = force_;
      discontinuity = discontinuity_;
      number = offered_count_;
    }
    const auto start = std::chrono::steady_clock::now();
    hub_.Publish(frame, force, discontinuity);
    const double ms = MillisecondsSince(start);
    {
      std::lock_guard lock(mu_);
      timing_.Add(ms);
      published_count_ = number;
    }
    published_.notify_all();
  }
}

}  // namespace dysa::service
