#include "view_stream.h"

#include <algorithm>
#include <iterator>

#include "dysa/codec/detail_subset.h"

namespace dysa::service {

namespace {

// The budget the stream's detail allows, as a particle count of the candidates.
uint64_t BudgetOf(uint32_t threshold, uint64_t candidates) {
  return threshold == 0 ? candidates
                        : std::max<uint64_t>(
                              1, uint64_t(codec::DetailFraction(threshold) * double(candidates)));
}

// The selection level `level` of a refinement asks for (level >= 1).
uint64_t LevelBudget(int level, uint64_t budget, uint64_t candidates) {
  return level >= 40 ? candidates : std::min(candidates, budget << level);
}

const ViewRead* ReadOf(const FrameSnapshot& snapshot, const ViewStream* stream) {
  for (const auto& r : snapshot.view_reads) {
    if (r && r->stream == stream) return r.get();
  }
  return nullptr;
}

}  // namespace

void ViewStream::SetView(const StreamView& view) {
  std::lock_guard lock(mu_);
  view_ = view;
  ++version_;
}

ViewRead ViewStream::Gather(const Simulation& sim, const FrameSnapshot& snapshot,
                            bool discontinuity, uint32_t threshold, uint32_t stride,
                            int keyframe_interval, const Simulation::ParticlesById& out) {
  StreamView view;
  ViewRead r;
  r.stream = this;
  {
    std::lock_guard lock(mu_);
    view = view_;
    r.view_version = version_;
  }
  r.threshold = threshold;
  r.stride = std::max<uint32_t>(1, stride);
  r.total = snapshot.positions.size() / 3;
  const Key key{r.view_version, r.threshold, r.stride, r.total};
  const uint64_t candidates = (r.total + r.stride - 1) / r.stride;
  const uint64_t budget = BudgetOf(threshold, candidates);

  r.seq = ++gathers_;
  // What Next may do with this frame, from the state it left. Frames gathered before this one
  // and not planned yet may still be planned first (with a publishing thread, up to two: one
  // being published, one waiting), each advancing the keyframe interval: hence the margin. A
  // frame dropped unplanned keeps it (conservative: at most two frames read both).
  bool may_select = false, may_keep = false, may_refine = false;
  std::vector<uint32_t> kept, shown;
  {
    std::lock_guard lock(state_mu_);
    const bool jump = discontinuity || pending_discontinuity_;
    const uint64_t in_flight = std::min<uint64_t>(2, r.seq - 1 - planned_seq_);
    may_select = jump || !(key == selected_key_) ||
                 uint64_t(frames_since_selection_) + in_flight >= uint64_t(keyframe_interval);
    // (Once the interval has passed, the next plan selects whatever came in between.)
    may_keep = !jump && key == selected_key_ && frames_since_selection_ < keyframe_interval;
    if (may_keep) kept = selected_, r.generation = generation_;
    may_refine = have_shown_ && !jump && partial_ && snapshot.frame == shown_frame_ &&
                 snapshot.step == shown_step_ && key == shown_key_;
    if (may_refine) shown = shown_, r.from_level = level_;
  }
  const ViewSubsetRequest request =
      ViewRequest(view, snapshot.domain_min, snapshot.domain_max, r.stride);
  if (may_select) {
    r.particles_read += sim.ReadViewSubset(request, budget, r.selection, out);
    r.selected = true;
  }
  if (may_refine) {
    // Next's loop: the next level whose selection adds to what is shown (the first one does
    // unless a selection was cut short).
    std::vector<uint32_t> added;
    r.level = r.from_level;
    while (added.empty() && shown.size() < candidates) {
      ++r.level;
      sim.ReadViewSubset(request, LevelBudget(r.level, budget, candidates), r.refinement, out);
      added.clear();
      std::set_difference(r.refinement.begin(), r.refinement.end(), shown.begin(), shown.end(),
                          std::back_inserter(added));
    }
    r.particles_read += r.refinement.size();
    r.refined = true;
    // The kept ids the refinement read already (all of them when they were chosen on this
    // frame) are not read again.
    std::vector<uint32_t> rest;
    std::set_difference(kept.begin(), kept.end(), r.refinement.begin(), r.refinement.end(),
                        std::back_inserter(rest));
    kept.swap(rest);
  }
  // A keyframe request on the frame shown sends the kept ids afresh, not a refinement.
  if (may_keep) {
    r.particles_read += sim.ReadParticlesByIds(kept, out);
    r.kept = true;
  }
  return r;
}

std::optional<ViewStream::Plan> ViewStream::Next(const FrameSnapshot& snapshot, bool fresh,
                                                 bool discontinuity, uint32_t threshold,
                                                 uint32_t stride, int keyframe_interval) {
  StreamView view;
  Key key;
  {
    std::lock_guard lock(mu_);
    view = view_;
    key.view_version = version_;
  }
  std::lock_guard state_lock(state_mu_);
  discontinuity = discontinuity || pending_discontinuity_;
  key.threshold = threshold;
  key.stride = std::max<uint32_t>(1, stride);
  key.total = snapshot.positions.size() / 3;
  const uint64_t candidates = (key.total + key.stride - 1) / key.stride;
  const uint64_t budget = BudgetOf(threshold, candidates);
  const auto order = [&] {
    return ViewOrder(view, snapshot.positions, snapshot.domain_min, snapshot.domain_max,
                     key.stride);
  };
  // Without every particle in the snapshot, what the simulation thread read for this stream.
  const ViewRead* read = snapshot.complete ? nullptr : ReadOf(snapshot, this);
  if (read) planned_seq_ = std::max(planned_seq_, read->seq);
  const bool read_fits = read && read->view_version == key.view_version &&
                         read->threshold == key.threshold && read->stride == key.stride &&
                         read->total == key.total;
  const auto missing = [&] {
    // The stream's state stays as it was; a discontinuity still selects at the next frame.
    pending_discontinuity_ = discontinuity;
    Plan plan;
    plan.missing = true;
    return plan;
  };

  const bool same_frame = have_shown_ && !fresh && !discontinuity &&
                          snapshot.frame == shown_frame_ && snapshot.step == shown_step_ &&
                          key == shown_key_;
  if (same_frame) {
    if (!partial_) return std::nullopt;  // the client has all of it
    if (!snapshot.complete && !(read_fits && read->refined && read->from_level == level_)) {
      return missing();
    }
    // The next budget whose selection adds something (the first one does unless the selection
    // had been cut short, which it never is for one view and frame).
    increment_.clear();
    if (snapshot.complete) {
      const ViewOrder ordered = order();
      while (increment_.empty() && shown_.size() < candidates) {
        ++level_;
        const std::vector<uint32_t> selection =
            ordered.Select(LevelBudget(level_, budget, candidates));
        std::set_difference(selection.begin(), selection.end(), shown_.begin(), shown_.end(),
                            std::back_inserter(increment_));
      }
    } else {  // the level Gather found, by the same loop on the same state
      level_ = read->level;
      std::set_difference(read->refinement.begin(), read->refinement.end(), shown_.begin(),
                          shown_.end(), std::back_inserter(increment_));
    }
    std::vector<uint32_t> merged;
    merged.reserve(shown_.size() + increment_.size());
    std::merge(shown_.begin(), shown_.end(), increment_.begin(), increment_.end(),
               std::back_inserter(merged));
    shown_.swap(merged);
    partial_ = shown_.size() < candidates;
    return Plan{increment_, true, partial_};
  }

  // A keyframe request alone (a subscriber missed a frame) keeps the subset: selecting is O(n),
  // and a slow link asks often.
  const bool select =
      discontinuity || !(key == selected_key_) || frames_since_selection_ >= keyframe_interval;
  if (!snapshot.complete) {
    const bool have = select ? read_fits && read->selected
                             : read_fits && read->kept && read->generation == generation_;
    if (!have) return missing();
  }
  if (select) {
    if (snapshot.complete) {
      selected_ = order().Select(budget);
    } else {
      selected_ = read->selection;
    }
    selected_key_ = key;
    frames_since_selection_ = 0;
    ++generation_;
  }
  pending_discontinuity_ = false;
  ++frames_since_selection_;
  have_shown_ = true;
  shown_frame_ = snapshot.frame;
  shown_step_ = snapshot.step;
  shown_key_ = key;
  shown_ = selected_;
  level_ = 0;
  partial_ = selected_.size() < candidates;
  return Plan{selected_, false, partial_};
}

}  // namespace dysa::service
