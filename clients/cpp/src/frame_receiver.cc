#include "dysa/client/frame_receiver.h"

#include <algorithm>
#include <utility>

#include "dysa/client/frame_assembler.h"

namespace dysa::remote {

namespace {
using Clock = std::chrono::steady_clock;
}  // namespace

FrameReceiver::FrameReceiver(const ConnectOptions& connect, const StreamOptions& stream)
    : client_(connect), options_(stream) {}

FrameReceiver::~FrameReceiver() { Stop(); }

void FrameReceiver::Start() {
  std::lock_guard lock(mu_);
  if (thread_.joinable()) return;
  stop_ = false;
  thread_ = std::thread([this] { Loop(); });
  camera_thread_ = std::thread([this] { CameraLoop(); });
}

void FrameReceiver::Stop() {
  {
    std::lock_guard lock(mu_);
    stop_ = true;
    if (open_stream_ != nullptr) open_stream_->Cancel();
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  if (camera_thread_.joinable()) camera_thread_.join();
}

void FrameReceiver::SetCamera(const StreamCamera& camera) {
  {
    std::lock_guard lock(mu_);
    camera_ = camera;
    camera_sent_ = false;
  }
  wake_.notify_all();
}

void FrameReceiver::CameraLoop() {
  std::unique_lock lock(mu_);
  for (;;) {
    wake_.wait(lock, [this] { return stop_ || (!camera_sent_ && server_stream_id_ != 0); });
    if (stop_) return;
    const StreamCamera camera = *camera_;
    const uint64_t id = server_stream_id_;
    camera_sent_ = true;
    lock.unlock();
    try {
      client_.SetStreamView(id, camera);
    } catch (const std::exception&) {
      // The stream ended meanwhile (NOT_FOUND) or the server is away: the next stream gets it.
    }
    // At most one camera per period: a drag sends the newest, not every mouse move.
    std::this_thread::sleep_for(kCameraPeriod);
    lock.lock();
  }
}

void FrameReceiver::SetStreamOptions(const StreamOptions& stream) {
  {
    std::lock_guard lock(mu_);
    options_ = stream;
    restart_ = true;
    if (open_stream_ != nullptr) open_stream_->Cancel();
  }
  wake_.notify_all();
}

bool FrameReceiver::TakeLatest(ReceivedFrame& out) {
  std::lock_guard lock(mu_);
  if (!have_latest_) return false;
  std::swap(out, latest_);
  have_latest_ = false;
  return true;
}

ReceiverStats FrameReceiver::Stats() const {
  std::lock_guard lock(mu_);
  ReceiverStats stats = stats_;
  // Frames over the last second, counted at the time of asking so a stalled stream reads 0.
  const Clock::time_point cutoff = Clock::now() - std::chrono::seconds(1);
  stats.frames_per_second =
      double(std::count_if(recent_.begin(), recent_.end(), [&](auto t) { return t >= cutoff; }));
  return stats;
}

void FrameReceiver::Loop() {
  // The pause before reconnecting doubles from 0.25 s up to 2 s while the server stays away,
  // so a restarted server is found again within 2 s without a busy loop meanwhile.
  std::chrono::milliseconds pause(250);
  for (;;) {
    StreamOptions options;
    {
      std::lock_guard lock(mu_);
      if (stop_) return;
      options = options_;
      restart_ = false;
    }
    const uint64_t frames_before = Stats().frames;
    const std::string error = RunStream(options);
    std::unique_lock lock(mu_);
    stats_.streaming = false;
    if (stop_) return;
    if (restart_) continue;  // new options: reconnect at once
    stats_.error = error.empty() ? "the server ended the stream" : error;
    ++stats_.reconnects;
    if (stats_.frames > frames_before) pause = std::chrono::milliseconds(250);
    wake_.wait_for(lock, pause, [this] { return stop_ || restart_; });
    pause = std::min(2 * pause, std::chrono::milliseconds(2000));
  }
}

std::string FrameReceiver::RunStream(const StreamOptions& options) {
  std::unique_ptr<FrameStream> stream;
  try {
    stream = client_.StreamFrames(options);
  } catch (const std::exception& e) {
    return e.what();
  }
  {
    std::lock_guard lock(mu_);
    if (stop_ || restart_) return "";
    open_stream_ = stream.get();
    ++stream_id_;
  }

  FrameAssembler assembler;
  ReceivedFrame decoded;
  FrameMessage message;
  while (stream->Next(message)) {
    const FrameProgress progress = assembler.Add(message, decoded.frame);
    bool new_stream = false;
    {
      std::lock_guard lock(mu_);
      if (progress.decode_error) ++stats_.decode_errors;
      stats_.frames_skipped += message.frames_skipped;
      if (progress.stream_id != server_stream_id_) {
        // A new call: it gets the camera too.
        server_stream_id_ = progress.stream_id;
        new_stream = camera_.has_value();
        if (new_stream) camera_sent_ = false;
      }
    }
    if (new_stream) wake_.notify_all();
    if (!progress.complete) continue;
    decoded.bytes = progress.frame_bytes;
    decoded.sim_frame = message.frame;
    decoded.latency_ms = progress.latency_ms;
    Publish(decoded);
  }

  std::string error;
  try {
    stream->Finish();
  } catch (const std::exception& e) {
    error = e.what();
  }
  std::lock_guard lock(mu_);
  open_stream_ = nullptr;
  server_stream_id_ = 0;
  if (stop_ || restart_) return "";
  return error;
}

void FrameReceiver::Publish(ReceivedFrame& decoded) {
  const Clock::time_point now = Clock::now();
  std::lock_guard lock(mu_);
  decoded.stream_id = stream_id_;
  // Swap rather than copy: the render thread's previous buffers come back for the next decode.
  // The decoder writes every element of the frame, so stale content never leaks through.
  std::swap(latest_, decoded);
  have_latest_ = true;
  stats_.streaming = true;
  stats_.error.clear();
  ++stats_.frames;
  stats_.bytes_per_frame = double(latest_.bytes);
  stats_.latency_ms = latest_.latency_ms;
  recent_.push_back(now);
  while (!recent_.empty() && now - recent_.front() > std::chrono::seconds(1)) recent_.pop_front();
}

}  // namespace dysa::remote
