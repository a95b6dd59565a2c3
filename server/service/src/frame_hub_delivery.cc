// FrameHub's delivery feedback (frame_hub.h): what each stream's link delivers (the frames it
// starts, the bytes its writes complete, frames late, the client's acknowledgements), which its
// detail controller turns into the detail it gets next; the budgets fitted to the particle
// count; and the per-stream reports of the status. The subscriptions, their groups and the
// publishing are frame_hub.cc's.
#include <memory>
#include <mutex>
#include <vector>

#include "dysa/service/frame_hub.h"
#include "view_stream.h"

namespace dysa::service {

void FrameHub::FitBudgetsTo(uint32_t total) {
  std::vector<std::shared_ptr<Subscription>> subscriptions;
  {
    std::lock_guard lock(mu_);
    last_total_ = total;
    subscriptions = subscriptions_;
  }
  // A subscriber whose controller has not seen this particle count yet (its first frame, a new
  // scene) gets the detail its particle budget allows before this frame is encoded.
  for (const auto& s : subscriptions) {
    uint32_t threshold = 0;
    {
      std::lock_guard lock(s->detail_mu_);
      if (!s->detail_->budget().active() || s->detail_->total() == total) continue;
      s->detail_->SetTotal(SteadySeconds(), total);
      threshold = s->detail_->threshold();
    }
    ApplyDetail(s, threshold);
  }
}

void FrameHub::FrameStarted(const std::shared_ptr<Subscription>& s, double now,
                            const EncodedFrame& frame, double produced) {
  uint32_t threshold = 0;
  {
    std::lock_guard lock(s->detail_mu_);
    s->detail_->OnSourceFrame(frame.frame, produced);
    s->detail_->OnFrameStart(now, frame.bytes, frame.particles, frame.total_particles,
                             frame.keyframe, produced);
    if (!s->detail_->budget().active()) return;
    threshold = s->detail_->threshold();
  }
  ApplyDetail(s, threshold);
}

void FrameHub::BytesDelivered(const std::shared_ptr<Subscription>& s, double now, size_t bytes,
                              bool frame_done) {
  uint32_t threshold = 0;
  bool budgeted = false;
  {
    std::lock_guard lock(s->detail_mu_);
    s->detail_->OnBytesDelivered(now, bytes, frame_done);
    threshold = s->detail_->threshold();
    budgeted = s->detail_->budget().active();
  }
  if (frame_done) MaybeRefine(s);
  if (budgeted) ApplyDetail(s, threshold);
}

void FrameHub::FrameLate(const std::shared_ptr<Subscription>& s, double now) {
  uint32_t threshold = 0;
  {
    std::lock_guard lock(s->detail_mu_);
    s->detail_->OnLate(now);
    if (!s->detail_->budget().active()) return;
    threshold = s->detail_->threshold();
  }
  ApplyDetail(s, threshold);
}

bool FrameHub::HoldFrame(const std::shared_ptr<Subscription>& s, double now) {
  std::lock_guard lock(s->detail_mu_);
  return s->detail_->Hold(now);
}

bool FrameHub::Acknowledge(uint64_t ack_token, double now, uint64_t frames, double rtt) {
  if (ack_token == 0) return false;
  std::shared_ptr<Subscription> s;
  {
    std::lock_guard lock(mu_);
    auto it = std::find_if(subscriptions_.begin(), subscriptions_.end(),
                           [&](const auto& x) { return x->ack_token_ == ack_token; });
    if (it == subscriptions_.end()) return false;
    s = *it;
  }
  uint32_t threshold = 0;
  bool budgeted = false;
  {
    std::lock_guard lock(s->detail_mu_);
    s->detail_->OnAcknowledged(now, frames, rtt);
    threshold = s->detail_->threshold();
    budgeted = s->detail_->budget().active();
  }
  if (budgeted) ApplyDetail(s, threshold);
  // A frame held back for this report may go now.
  {
    std::lock_guard lock(s->frame_mu_);
    if (!s->pending_) return true;
  }
  std::lock_guard lock(s->listener_mu_);
  if (s->listener_) s->listener_->OnMayWrite();
  return true;
}

std::vector<StreamReport> FrameHub::StreamReports(double now) const {
  std::vector<std::shared_ptr<Subscription>> subscriptions;
  {
    std::lock_guard lock(mu_);
    subscriptions = subscriptions_;
  }
  std::vector<StreamReport> reports;
  for (const auto& s : subscriptions) {
    std::lock_guard lock(s->detail_mu_);
    reports.push_back({s->detail_->budget(), s->detail_->Status(now), s->id_, s->view_ != nullptr});
  }
  return reports;
}

}  // namespace dysa::service
