// Receives the particle stream on a background thread: one StreamFrames call at a time,
// decoded as it arrives (FrameAssembler), the newest complete frame kept for the caller (the
// viewer's render thread), who never waits on the network: TakeLatest() only swaps buffers under
// a short lock. When the stream ends (server restart, network loss) it reconnects with a growing
// pause.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "dysa/client/client.h"
#include "dysa/codec/frame_codec.h"

namespace dysa::remote {

struct ReceivedFrame {
  codec::Frame frame;      // decoded, in id order
  uint64_t sim_frame = 0;  // the server's frame number since its last reset
  uint64_t bytes = 0;      // codec bytes of this frame on the wire
  double latency_ms = 0;   // from the server producing it to it being decoded here
  uint64_t stream_id = 0;  // which connection delivered it (changes after a reconnect)
};

struct ReceiverStats {
  bool streaming = false;        // a stream is open and has delivered a frame
  std::string error;             // why the last stream ended, "" if it has not
  double frames_per_second = 0;  // frames received over the last second
  double bytes_per_frame = 0;    // of the newest frame
  double latency_ms = 0;         // of the newest frame
  uint64_t frames = 0;           // received since start
  uint64_t frames_skipped = 0;   // frames the server skipped for us (latest-wins)
  uint64_t decode_errors = 0;
  uint64_t reconnects = 0;
};

class FrameReceiver {
 public:
  // Throws std::runtime_error when the TLS CA file cannot be read.
  FrameReceiver(const ConnectOptions& connect, const StreamOptions& stream);
  ~FrameReceiver();  // Stop()
  FrameReceiver(const FrameReceiver&) = delete;
  FrameReceiver& operator=(const FrameReceiver&) = delete;

  void Start();
  void Stop();

  // Restarts the stream with new options (fields, frame-rate cap, stride, bits).
  void SetStreamOptions(const StreamOptions& stream);

  // The camera to give the stream (Client::SetStreamView): sent from a thread of its own at most
  // every kCameraPeriod, the latest one only, and again after a reconnect. Never blocks.
  void SetCamera(const StreamCamera& camera);
  static constexpr std::chrono::milliseconds kCameraPeriod{100};

  // When a frame arrived since the previous call, swaps it into `out` (whose buffers are
  // recycled) and returns true.
  bool TakeLatest(ReceivedFrame& out);

  ReceiverStats Stats() const;

 private:
  void Loop();
  // One StreamFrames call until it ends; returns why ("" when stopped or restarted by us).
  std::string RunStream(const StreamOptions& options);
  void Publish(ReceivedFrame& decoded);
  // Sends the camera whenever it changed or the stream did (camera_thread_).
  void CameraLoop();

  Client client_;

  mutable std::mutex mu_;
  std::condition_variable wake_;
  StreamOptions options_;
  bool restart_ = false;
  bool stop_ = false;
  FrameStream* open_stream_ = nullptr;  // to cancel it from Stop/SetStreamOptions
  ReceivedFrame latest_;
  bool have_latest_ = false;
  ReceiverStats stats_;
  std::deque<std::chrono::steady_clock::time_point> recent_;  // arrival times, last second
  uint64_t stream_id_ = 0;
  uint64_t server_stream_id_ = 0;  // FrameMessage.stream_id of the open call; 0: none yet
  std::optional<StreamCamera> camera_;
  bool camera_sent_ = true;  // the latest camera went to the open call

  std::thread thread_;
  std::thread camera_thread_;
};

}  // namespace dysa::remote
