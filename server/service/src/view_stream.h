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
#pragma once

#include <atomic>
#include <cstdint>
#include <mutex>
#include <optional>
#include <span>
#include <vector>

#include "dysa/service/frame_hub.h"
#include "dysa/service/view_detail.h"

namespace dysa::service {

class ViewStream {
 public:
  // Any thread. `view` must be valid.
  void SetView(const StreamView& view);

  // What to send of a frame (the publishing thread).
  struct Plan {
    std::span<const uint32_t> ids;  // increasing; valid until the next call
    bool refines = false;           // adds `ids` to the frame sent before (the same frame)
    bool partial = false;           // the client's frame still lacks some particles
  };
  // `fresh`: the frame must be sent afresh, not refined (a keyframe was asked for: the client
  // may lack the frame shown); `discontinuity`: it does not follow the previous one (reset, step
  // back, new scene: select again). `threshold`: the stream's detail (codec::DetailThreshold;
  // 0: every candidate). Nothing when the snapshot is the frame already sent in full.
  std::optional<Plan> Next(const FrameSnapshot& snapshot, bool fresh, bool discontinuity,
                           uint32_t threshold, uint32_t stride, int keyframe_interval);

  // Whether the frame last planned is incomplete: a refinement would add to it.
  bool partial() const { return partial_; }

 private:
  std::mutex mu_;
  StreamView view_;
  uint64_t version_ = 0;  // +1 per SetView

  // The publishing thread's.
  struct Key {
    uint64_t view_version = 0;
    uint32_t threshold = 0, stride = 0;
    size_t total = 0;
    bool operator==(const Key&) const = default;
  };
  Key selected_key_;
  std::vector<uint32_t> selected_;  // the subset new frames are sent
  int frames_since_selection_ = 0;
  bool have_shown_ = false;
  uint64_t shown_frame_ = 0, shown_step_ = 0;
  Key shown_key_;
  std::vector<uint32_t> shown_;      // every id the client holds of the shown frame
  std::vector<uint32_t> increment_;  // the latest refinement's ids
  int level_ = 0;                    // refinements of the shown frame so far
  std::atomic<bool> partial_{false};
};

}  // namespace dysa::service
