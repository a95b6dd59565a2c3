#include "view_stream.h"

#include <algorithm>
#include <iterator>

#include "dysa/codec/detail_subset.h"

namespace dysa::service {

void ViewStream::SetView(const StreamView& view) {
  std::lock_guard lock(mu_);
  view_ = view;
  ++version_;
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
  key.threshold = threshold;
  key.stride = std::max<uint32_t>(1, stride);
  key.total = snapshot.positions.size() / 3;
  const uint64_t candidates = (key.total + key.stride - 1) / key.stride;
  // The budget the stream's detail allows, as a particle count of the candidates.
  const uint64_t budget =
      threshold == 0
          ? candidates
          : std::max<uint64_t>(1, uint64_t(codec::DetailFraction(threshold) * double(candidates)));
  const auto order = [&] {
    return ViewOrder(view, snapshot.positions, snapshot.domain_min, snapshot.domain_max,
                     key.stride);
  };

  const bool same_frame = have_shown_ && !fresh && !discontinuity &&
                          snapshot.frame == shown_frame_ && snapshot.step == shown_step_ &&
                          key == shown_key_;
  if (same_frame) {
    if (!partial_) return std::nullopt;  // the client has all of it
    // The next budget whose selection adds something (the first one does unless the selection
    // had been cut short, which it never is for one view and frame).
    increment_.clear();
    const ViewOrder ordered = order();
    while (increment_.empty() && shown_.size() < candidates) {
      ++level_;
      const uint64_t next = level_ >= 40 ? candidates : std::min(candidates, budget << level_);
      const std::vector<uint32_t> selection = ordered.Select(next);
      std::set_difference(selection.begin(), selection.end(), shown_.begin(), shown_.end(),
                          std::back_inserter(increment_));
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
  if (discontinuity || !(key == selected_key_) || frames_since_selection_ >= keyframe_interval) {
    selected_ = order().Select(budget);
    selected_key_ = key;
    frames_since_selection_ = 0;
  }
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
