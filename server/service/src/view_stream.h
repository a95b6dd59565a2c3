// One subscriber's view-dependent stream (FrameHub::SetStreamView): its camera, the subset it is
// sent (view_detail.h) and the progressive completion of a frame that stays on screen.
//
// A new frame is sent as the view subset of the budget. The subset is re-selected only when the
// camera, the budget or the particle count changed, after a discontinuity, or once per keyframe
// interval (the particles' cells drift as the fluid moves), so between those the same ids go out
// and delta coding pays. A republish of the frame already sent (the server is paused and asks
// for a frame) instead sends a refinement: the particles of the selection at twice the previous
// budget that were not sent yet. Those nest, so after at most ceil(log2(candidates / budget))
// refinements the client holds every particle of the frame; their positions are quantised over
// the whole frame's range (codec), so the assembled frame is bit-exactly the full-detail one.
//
// Where the particles are read. A snapshot that holds every particle (FrameSnapshot::complete)
// lets Next choose on the host (ViewOrder). Otherwise the simulation thread first asks Gather
// to read what Next may need of this frame (a ViewRead): the new selection, chosen where the
// particles live (Simulation::ReadViewSubset), when Next may re-select; the kept ids' particles
// (Simulation::ReadParticlesByIds) when it may keep them; the next refinement's selection when
// the frame is the one shown. Gather cannot know for sure (the publishing thread plans later, a
// frame may be dropped in between), so it reads both around a re-selection; when what it read
// does not fit after all, Next says so (Plan::missing) and the hub asks for another frame.
#pragma once

#include <atomic>
#include <cstdint>
#include <mutex>
#include <optional>
#include <span>
#include <vector>

#include "dysa/core/simulation.h"
#include "dysa/service/frame_hub.h"
#include "dysa/service/view_detail.h"

namespace dysa::service {

// What the simulation thread read of one frame for one view stream (ViewStream::Gather): the
// particles at these ids are valid in the snapshot's arrays, for the stream's fields.
struct ViewRead {
  const ViewStream* stream = nullptr;
  uint64_t seq = 0;  // the stream's gathers, from 1
  uint64_t view_version = 0;
  uint32_t threshold = 0, stride = 1;
  size_t total = 0;
  bool selected = false;            // `selection`: the budget's selection on this frame
  std::vector<uint32_t> selection;  // increasing
  bool kept = false;                // the kept ids of selection number `generation` were read
  uint64_t generation = 0;
  bool refined = false;              // `refinement`: the selection of level `level`, the first past
  int from_level = 0, level = 0;     // `from_level` that adds to the ids shown
  std::vector<uint32_t> refinement;  // increasing
  size_t particles_read = 0;         // particles the simulation handed over for this stream
};

class ViewStream {
 public:
  // Any thread. `view` must be valid.
  void SetView(const StreamView& view);

  // What to send of a frame (the publishing thread).
  struct Plan {
    std::span<const uint32_t> ids;  // increasing; valid until the next call
    bool refines = false;           // adds `ids` to the frame sent before (the same frame)
    bool partial = false;           // the client's frame still lacks some particles
    // The snapshot lacks what this frame needs (it was read for another plan): nothing is sent,
    // the stream's state is unchanged, and a later frame (read anew) sends it.
    bool missing = false;
  };
  // `fresh`: the frame must be sent afresh, not refined (a keyframe was asked for: the client
  // may lack the frame shown); `discontinuity`: it does not follow the previous one (reset, step
  // back, new scene: select again). `threshold`: the stream's detail (codec::DetailThreshold;
  // 0: every candidate). Nothing when the snapshot is the frame already sent in full.
  std::optional<Plan> Next(const FrameSnapshot& snapshot, bool fresh, bool discontinuity,
                           uint32_t threshold, uint32_t stride, int keyframe_interval);

  // Whether the frame last planned is incomplete: a refinement would add to it.
  bool partial() const { return partial_; }

  // The simulation thread, for a snapshot that will not hold every particle: reads into `out`
  // (the snapshot's arrays) what Next may need of the current frame, and says what it read.
  // `snapshot`: its frame, step, domain and particle count (positions.size() / 3) are set.
  // `discontinuity` as in Next; threshold, stride and interval: the stream's group's.
  ViewRead Gather(const Simulation& sim, const FrameSnapshot& snapshot, bool discontinuity,
                  uint32_t threshold, uint32_t stride, int keyframe_interval,
                  const Simulation::ParticlesById& out);

 private:
  std::mutex mu_;
  StreamView view_;
  uint64_t version_ = 0;  // +1 per SetView

  // Written by the publishing thread (Next) under state_mu_, read by Gather.
  std::mutex state_mu_;
  struct Key {
    uint64_t view_version = 0;
    uint32_t threshold = 0, stride = 0;
    size_t total = 0;
    bool operator==(const Key&) const = default;
  };
  Key selected_key_;
  std::vector<uint32_t> selected_;  // the subset new frames are sent
  uint64_t generation_ = 0;         // +1 per selection
  int frames_since_selection_ = 0;
  bool pending_discontinuity_ = false;  // a discontinuity's frame was missing: select at the next
  uint64_t planned_seq_ = 0;            // the latest gather (ViewRead::seq) a plan has seen
  uint64_t gathers_ = 0;                // the simulation thread's (Gather)
  bool have_shown_ = false;
  uint64_t shown_frame_ = 0, shown_step_ = 0;
  Key shown_key_;
  std::vector<uint32_t> shown_;      // every id the client holds of the shown frame
  std::vector<uint32_t> increment_;  // the latest refinement's ids
  int level_ = 0;                    // refinements of the shown frame so far
  std::atomic<bool> partial_{false};
};

}  // namespace dysa::service
