// Publishing frames off the simulation thread.
//
// Encoding a frame and starting its writes takes a few milliseconds per frame (bench/README.md,
// server_bench); done on the simulation thread, every step waits for it. The simulation thread
// only gathers the particles into a FrameSnapshot and offers it here, which swaps buffers; this
// class's own thread encodes and hands the frame to the hub. With a core left to it (dysa-server
// --threads below the core count), streaming then costs the solver the gather alone.
//
// That needs a core: when the solver has every core, a publishing thread only takes its cycles
// from the solver's threads, and each step's barriers then wait for the one it preempted. The
// publisher is then inline: Offer publishes on the caller's thread, whose OpenMP team encodes
// while the solver waits anyway.
//
// A frame offered while the previous one is still being published replaces the one waiting
// (subscribers get the newest frame; the hub's encoders take any sequence of frames). A forced
// frame, one a control asked for (step, step back, reset, a late joiner while paused), is waited
// for: the control's reply then follows its frame, as when publishing was synchronous.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>

#include "dysa/core/simulation.h"
#include "dysa/service/frame_hub.h"

namespace dysa::service {

// Fills `snapshot` from the simulation's current frame: positions, and velocities or densities
// when `fields` (codec fields) need them, scattered from storage order into id order. With a
// `threshold` (FrameHub::NeededThreshold) only the particles of DetailRank(id) below it are
// copied (snapshot.threshold says so), on any device: on a GPU they are chosen there and only
// they cross to the host (Simulation::ReadParticlesByIdBelowRank).
void GatherSnapshot(const Simulation& sim, uint32_t fields, uint32_t threshold,
                    FrameSnapshot& snapshot);
// Fills `snapshot` with what `hub`'s streams need of the simulation's current frame. With view
// streams (FrameHub::SetStreamView) and no stream of every particle, only what each view stream
// sends is read (ViewStream::Gather: its selection, chosen where the particles live, or the ids
// it keeps, or its next refinement), with the streams without a camera's subset by rank and
// every particle's position extremes (the codec's range for a view keyframe); otherwise as
// above. `discontinuity`: the frame does not follow the previous one (FrameHub::Publish's).
// Unless `any_time` (a forced publish) or a discontinuity, only for the streams that would take
// the frame now (FrameHub::GatherNeeds); false, nothing read, when none would.
// snapshot.particles_read says how many particles were read.
bool GatherSnapshot(const Simulation& sim, const FrameHub& hub, bool any_time, bool discontinuity,
                    FrameSnapshot& snapshot);

// The time a per-frame stage took (gathering a frame, publishing it), as GetStatus shows it.
struct StageTiming {
  double last_ms = 0;
  double mean_ms = 0;
  uint64_t calls = 0;  // frames
  void Add(double ms) {
    last_ms = ms;
    mean_ms = (mean_ms * double(calls) + ms) / double(calls + 1);
    ++calls;
  }
};

class FramePublisher {
 public:
  // `threads`: OpenMP threads of the publishing thread (the encoder's chunks run in parallel);
  // 0: no thread, publish inline on the caller's.
  FramePublisher(FrameHub& hub, int threads);
  ~FramePublisher();  // Stop()
  FramePublisher(const FramePublisher&) = delete;
  FramePublisher& operator=(const FramePublisher&) = delete;

  // Takes `snapshot` (swapping it with a spare buffer, so `snapshot` comes back holding an older
  // frame's arrays to be overwritten). `force` and `discontinuity` as in FrameHub::Publish; a
  // replaced frame's flags carry over to the one replacing it. Returns once a forced frame is
  // published, at once otherwise.
  void Offer(FrameSnapshot& snapshot, bool force, bool discontinuity);
  // Publishes nothing more; a frame still waiting is dropped. Idempotent.
  void Stop();

  // The latest frame's encoding and hand-over to the subscribers, and their mean.
  StageTiming timing() const;
  void ResetTiming();

 private:
  void Loop(int threads);

  FrameHub& hub_;
  mutable std::mutex mu_;
  std::condition_variable offered_;
  std::condition_variable published_;
  FrameSnapshot waiting_;  // the frame to publish next, while `has_waiting_`
  bool has_waiting_ = false;
  bool force_ = false;
  bool discontinuity_ = false;
  uint64_t offered_count_ = 0;    // frames offered, the latest one's number
  uint64_t published_count_ = 0;  // the number of the latest frame published (or replaced)
  bool stop_ = false;
  StageTiming timing_;
  std::thread thread_;
};

}  // namespace dysa::service
