// dysa watch: the frame stream's rate, size and latency, live or as a JSON summary.
#include <algorithm>
#include <chrono>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <ostream>
#include <string>

#include "dysa/client/frame_assembler.h"
#include "dysa/codec/detail_subset.h"
#include "remote_commands.h"
#include "remote_format.h"
#include "stream_watchdog.h"

namespace dysa::remote {
namespace {

using Clock = std::chrono::steady_clock;

// What `watch` shows, updated by the reading thread and printed by the watchdog's.
struct WatchStats {
  std::mutex mutex;
  Clock::time_point start = Clock::now();
  uint64_t frames = 0;  // complete, decoded
  uint64_t bytes = 0;   // of those frames
  uint64_t frames_skipped = 0;
  uint64_t decode_errors = 0;
  std::deque<Clock::time_point> recent;  // when the frames of the last second completed
  // The latest frame.
  bool have_frame = false;
  uint64_t frame = 0;
  double time = 0;
  uint32_t particles = 0;
  double detail = 1;  // fraction of the particles the frame holds
  uint64_t frame_bytes = 0;
  double latency_ms = 0;
  double first_frame_s = -1;  // s from the start to the first complete frame; -1: none

  void Trim(Clock::time_point now) {
    while (!recent.empty() && now - recent.front() > std::chrono::seconds(1)) recent.pop_front();
  }

  double RecentRate(Clock::time_point now) {
    Trim(now);
    const double window = std::min(std::chrono::duration<double>(now - start).count(), 1.0);
    return window > 0 ? double(recent.size()) / window : 0;
  }

  std::string Line(const std::string& address) {
    std::lock_guard lock(mutex);
    const Clock::time_point now = Clock::now();
    const double rate = RecentRate(now);
    if (!have_frame) {
      const double waited = std::chrono::duration<double>(now - start).count();
      return "waiting for frames from " + address +
             (waited >= 2 ? " (" + Fixed(waited, 0) + " s; is the simulation paused?)" : "");
    }
    std::string line = "frame " + std::to_string(frame) + "  t " + Fixed(time, 3) + " s  " +
                       std::to_string(particles) + " particles" +
                       (detail < 1 ? " (detail " + Fixed(detail, 3) + ")" : "") + "  " +
                       Fixed(rate, 1) + " frames/s  " + HumanBytes(double(frame_bytes)) +
                       "/frame  " + Fixed(particles ? double(frame_bytes) / particles : 0, 2) +
                       " B/particle  latency " + Fixed(latency_ms, 1) + " ms";
    if (frames_skipped) line += "  skipped " + std::to_string(frames_skipped);
    if (decode_errors) line += "  decode errors " + std::to_string(decode_errors);
    return line;
  }
};

}  // namespace

void Watch(Client& client, const WatchOptions& options, std::ostream& out) {
  // Once, before the frames: what runs where (frames carry neither scene nor device).
  const ServerStatus status = client.GetStatus();
  if (!options.json) {
    out << "watching " << status.scene << " (solver " << status.solver << ") on "
        << DeviceText(status) << "\n"
        << std::flush;
  }
  std::unique_ptr<FrameStream> stream = client.StreamFrames(options.stream);
  WatchStats stats;
  const std::string address = client.address();
  size_t last_width = 0;
  auto print = [&] {
    const std::string line = stats.Line(address);
    if (options.live) {
      // Rewrite the line in place; blanks clear what a longer previous line left.
      out << "\r" << line
          << std::string(last_width > line.size() ? last_width - line.size() : 0, ' ')
          << std::flush;
      last_width = line.size();
    } else {
      out << line << std::endl;
    }
  };
  std::function<void()> tick;
  if (!options.json) tick = print;
  StreamWatchdog watchdog(*stream, options.interrupted, options.seconds,
                          options.live ? std::chrono::milliseconds(250) : std::chrono::seconds(1),
                          tick);

  FrameAssembler assembler;
  codec::Frame frame;
  FrameMessage message;
  uint64_t message_skips = 0;
  bool camera_sent = false;
  while (stream->Next(message)) {
    message_skips += message.frames_skipped;
    const FrameProgress progress = assembler.Add(message, frame);
    if (options.camera && !camera_sent && progress.stream_id != 0) {
      client.SetStreamView(progress.stream_id, *options.camera);  // RpcError: a bad camera
      camera_sent = true;
    }
    if (progress.decode_error) {
      std::lock_guard lock(stats.mutex);
      ++stats.decode_errors;
    }
    if (!progress.complete) continue;
    std::lock_guard lock(stats.mutex);
    ++stats.frames;
    stats.bytes += progress.frame_bytes;
    stats.frames_skipped = message_skips;
    const Clock::time_point now = Clock::now();
    if (stats.first_frame_s < 0) {
      stats.first_frame_s = std::chrono::duration<double>(now - stats.start).count();
    }
    stats.recent.push_back(now);
    stats.Trim(now);
    stats.have_frame = true;
    stats.frame = message.frame;
    stats.time = frame.time;
    stats.particles = frame.count;
    stats.detail = codec::DetailFraction(frame.detail_threshold);
    stats.frame_bytes = progress.frame_bytes;
    stats.latency_ms = progress.latency_ms;
  }
  watchdog.Stop();
  stream->Finish();  // throws unless the stream was ours to end

  const double seconds = std::chrono::duration<double>(Clock::now() - stats.start).count();
  std::lock_guard lock(stats.mutex);
  const double rate = seconds > 0 ? double(stats.frames) / seconds : 0;
  const double per_frame = stats.frames ? double(stats.bytes) / double(stats.frames) : 0;
  if (options.json) {
    return PrintJson({{"frames", stats.frames},
                      {"seconds", seconds},
                      {"frames_per_second", rate},
                      {"first_frame_s", stats.first_frame_s},
                      {"bytes", stats.bytes},
                      {"bytes_per_frame", per_frame},
                      {"last_frame", stats.frame},
                      {"time", stats.time},
                      {"particles", stats.particles},
                      {"detail", stats.detail},
                      {"frames_skipped", stats.frames_skipped},
                      {"decode_errors", stats.decode_errors},
                      {"device", status.device}},
                     out);
  }
  if (options.live) out << "\n";
  out << "watched " << Fixed(seconds, 1) << " s: " << stats.frames << " frames (" << Fixed(rate, 1)
      << " frames/s), " << HumanBytes(per_frame) << "/frame";
  if (stats.frames_skipped) out << ", " << stats.frames_skipped << " skipped";
  if (stats.decode_errors) out << ", " << stats.decode_errors << " decode errors";
  if (stats.first_frame_s >= 0)
    out << ", the first after " << Fixed(stats.first_frame_s, 2) << " s";
  out << "\n";
}

}  // namespace dysa::remote
