// How fast a view stream follows its viewer over a link (issue 32's targets "a coarse view within
// 0.5 s after the camera jumps" and "full frame on pause within 1 s"). Driven by
// bench/view_link_bench.sh, which starts dysa-server and the link (dysa-delay-relay); this end is
// the viewer: it subscribes with a frame-rate target (the server picks the detail the link
// holds), gives the stream camera A, then jumps between cameras B and A every --dwell seconds,
// and at the end pauses the server and waits for the complete frame.
//
// Per jump it measures, from the frames as they complete here (decoded, as the viewer has them):
//   shown_at_jump  the particles inside the new camera's frustum in the frame shown when the
//                  camera jumps (the coarse share outside the old view: what the viewer draws at
//                  once), as a share of the steady count below;
//   steady         the median count inside the new frustum over the dwell's second half;
//   t_half, t_90   seconds from SetStreamView to the first frame holding half and 90% of it;
//   t_view         to the first frame chosen for the new view, coarse or not: whose share of
//                  particles inside the new view is at least half the settled frames' share.
// For the pause: seconds from Pause to the first frame that is not partial (every particle, the
// positions bit-exact as quantised), the refinements and bytes on the way.
// Prints a line per event and appends rows to --csv.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "dysa/client/client.h"
#include "dysa/client/frame_assembler.h"

namespace {

using Clock = std::chrono::steady_clock;
using dysa::remote::StreamCamera;
using Vec = std::array<double, 3>;

double Dot(const Vec& a, const Vec& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec Cross(const Vec& a, const Vec& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Vec Unit(const Vec& a) {
  const double n = std::sqrt(Dot(a, a));
  return {a[0] / n, a[1] / n, a[2] / n};
}

// Whether a point projects inside the camera's image (in front of the eye, within both half
// angles): what the viewer would draw of it.
class Frustum {
 public:
  explicit Frustum(const StreamCamera& c) : eye_(c.eye) {
    forward_ = Unit({c.target[0] - c.eye[0], c.target[1] - c.eye[1], c.target[2] - c.eye[2]});
    right_ = Unit(Cross(forward_, c.up));
    up_ = Cross(right_, forward_);
    tan_y_ = std::tan(0.5 * c.fov_y_deg * std::acos(-1.0) / 180);
    tan_x_ = c.aspect * tan_y_;
  }
  bool Contains(const float* p) const {
    const Vec r{p[0] - eye_[0], p[1] - eye_[1], p[2] - eye_[2]};
    const double depth = Dot(r, forward_);
    return depth > 0 && std::abs(Dot(r, right_)) <= tan_x_ * depth &&
           std::abs(Dot(r, up_)) <= tan_y_ * depth;
  }

 private:
  Vec eye_, forward_{}, right_{}, up_{};
  double tan_x_ = 0, tan_y_ = 0;
};

StreamCamera ParseCamera(const std::string& text, double fov, double aspect) {
  std::vector<double> v;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) v.push_back(std::stod(item));
  if (v.size() != 6) throw CLI::ValidationError("camera", "EX,EY,EZ,TX,TY,TZ (m), 6 numbers");
  StreamCamera c;
  c.eye = {v[0], v[1], v[2]};
  c.target = {v[3], v[4], v[5]};
  c.fov_y_deg = fov;
  c.aspect = aspect;
  return c;
}

// One completed frame as the viewer has it.
struct Received {
  double t = 0;  // s since the bench began
  uint64_t frame = 0;
  uint32_t count = 0;
  uint32_t in_a = 0, in_b = 0;  // particles inside camera A's and B's frusta
  bool partial = false, refined = false;
  uint64_t bytes = 0;
};

struct Log {
  std::mutex mu;
  std::condition_variable changed;
  std::vector<Received> frames;
  uint64_t stream_id = 0;
  bool ended = false;
};

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

}  // namespace

// The default cameras suit link_watch_bench's dam break (a 0.5 x 1 x 0.5 m column at the left
// of a 2 x 1.25 x 0.5 m tank), seen from the front through 12 degrees: A the column's foot, B the
// floor just right of it, where the surge runs; their frusta do not meet, and both hold water
// from the release on.
int main(int argc, char** argv) {
  CLI::App app{"view_link_bench: a view stream's response to camera jumps and to a pause"};
  std::string server, camera_a = "0.12,0.12,1.25,0.12,0.12,0.25",
                      camera_b = "0.55,0.12,1.25,0.55,0.12,0.25";
  std::string csv = "bench/results/view_link.csv", label;
  double fps_target = 30, fov = 12, aspect = 1.6, settle = 5, dwell = 4, pause_wait = 60;
  int jumps = 4;
  app.add_option("--server", server, "the server, or the link's near end")->required();
  app.add_option("--fps-target", fps_target, "the stream's frame-rate target")
      ->check(CLI::Range(0.1, 1000.0));
  app.add_option("--camera-a", camera_a, "EX,EY,EZ,TX,TY,TZ (m): the first camera");
  app.add_option("--camera-b", camera_b, "EX,EY,EZ,TX,TY,TZ (m): the camera it jumps to");
  app.add_option("--fov", fov, "vertical field of view, degrees")->check(CLI::Range(1.0, 179.0));
  app.add_option("--settle", settle, "seconds on camera A before the first jump")
      ->check(CLI::Range(0.0, 600.0));
  app.add_option("--dwell", dwell, "seconds on each camera after a jump")
      ->check(CLI::Range(0.5, 600.0));
  app.add_option("--jumps", jumps, "camera jumps (B, A, B, ...)")->check(CLI::Range(0, 100));
  app.add_option("--pause-wait", pause_wait, "seconds to wait for the complete frame on pause")
      ->check(CLI::Range(1.0, 3600.0));
  app.add_option("--csv", csv, "rows are appended here");
  app.add_option("--label", label, "the run's name in the CSV (e.g. particles and link)");
  CLI11_PARSE(app, argc, argv);
  const StreamCamera cam[2] = {ParseCamera(camera_a, fov, aspect),
                               ParseCamera(camera_b, fov, aspect)};
  const Frustum frustum[2] = {Frustum(cam[0]), Frustum(cam[1])};

  dysa::remote::ConnectOptions connect;
  connect.address = server;
  dysa::remote::Client client(connect);
  const auto start = Clock::now();
  const auto since = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };

  dysa::remote::StreamOptions options;
  options.fps_target = fps_target;
  std::unique_ptr<dysa::remote::FrameStream> stream = client.StreamFrames(options);
  Log log;
  std::thread reader([&] {
    dysa::remote::FrameAssembler assembler;
    dysa::codec::Frame frame;
    dysa::remote::FrameMessage message;
    while (stream->Next(message)) {
      const dysa::remote::FrameProgress p = assembler.Add(message, frame);
      if (p.stream_id != 0 && log.stream_id == 0) {
        std::lock_guard lock(log.mu);
        log.stream_id = p.stream_id;
        log.changed.notify_all();
      }
      if (!p.complete) continue;
      Received r{since(), message.frame, frame.count, 0, 0, p.partial, p.refined, p.frame_bytes};
      for (uint32_t i = 0; i < frame.count; ++i) {
        r.in_a += frustum[0].Contains(&frame.positions[3 * i]);
        r.in_b += frustum[1].Contains(&frame.positions[3 * i]);
      }
      std::lock_guard lock(log.mu);
      log.frames.push_back(r);
      log.changed.notify_all();
    }
    std::lock_guard lock(log.mu);
    log.ended = true;
    log.changed.notify_all();
  });
  const auto wait_for = [&](double seconds, auto done) {
    std::unique_lock lock(log.mu);
    return log.changed.wait_for(lock, std::chrono::duration<double>(seconds),
                                [&] { return log.ended || done(); });
  };
  if (!wait_for(60, [&] { return log.stream_id != 0; }) || log.stream_id == 0) {
    std::fprintf(stderr, "view_link_bench: no frame in 60 s\n");
    stream->Cancel();
    reader.join();
    return 1;
  }
  client.SetStreamView(log.stream_id, cam[0]);
  std::this_thread::sleep_for(std::chrono::duration<double>(settle));

  std::vector<double> jump_at;
  for (int j = 0; j < jumps; ++j) {
    jump_at.push_back(since());
    client.SetStreamView(log.stream_id, cam[(j + 1) % 2]);
    std::this_thread::sleep_for(std::chrono::duration<double>(dwell));
  }
  const double pause_at = since();
  client.Pause();
  const bool completed = wait_for(pause_wait, [&] {
    return !log.frames.empty() && log.frames.back().t > pause_at && !log.frames.back().partial;
  });
  const double paused_end = since();
  stream->Cancel();
  reader.join();
  client.Resume();

  std::ofstream out(csv, std::ios::app);
  if (out.tellp() == 0) {
    out << "label,event,at_s,frames,particles_per_frame,steady_in_view,shown_at_jump_share,"
           "t_half_s,t_90_s,complete_s,refinements,bytes,t_view_s\n";
  }
  const std::vector<Received>& f = log.frames;
  for (size_t j = 0; j < jump_at.size(); ++j) {
    const int to = int((j + 1) % 2);
    const double t0 = jump_at[j], t1 = j + 1 < jump_at.size() ? jump_at[j + 1] : pause_at;
    const auto in_view = [&](const Received& r) { return double(to == 0 ? r.in_a : r.in_b); };
    const auto share = [&](const Received& r) { return r.count ? in_view(r) / r.count : 0.0; };
    std::vector<double> late, late_share, counts;
    double shown = 0;
    size_t frames = 0;
    for (const Received& r : f) {
      if (r.t <= t0) shown = in_view(r);
      if (r.t > t0 && r.t <= t1) ++frames, counts.push_back(r.count);
      if (r.t > 0.5 * (t0 + t1) && r.t <= t1) {
        late.push_back(in_view(r));
        late_share.push_back(share(r));
      }
    }
    const double steady = Median(late), steady_share = Median(late_share);
    double t_half = -1, t_90 = -1, t_view = -1;
    for (const Received& r : f) {
      if (r.t <= t0 || r.t > t1) continue;
      if (t_view < 0 && share(r) >= 0.5 * steady_share && steady_share > 0) t_view = r.t - t0;
      if (t_half < 0 && in_view(r) >= 0.5 * steady) t_half = r.t - t0;
      if (t_90 < 0 && in_view(r) >= 0.9 * steady) t_90 = r.t - t0;
    }
    char line[512];
    std::snprintf(line, sizeof line,
                  "jump to %c at %.1f s: %zu frames of %.0f particles, %.0f in view when steady, "
                  "%.0f%% of them shown at once, the new view's first frame in %.3f s, half in "
                  "%.3f s, 90%% in %.3f s",
                  to == 0 ? 'A' : 'B', t0, frames, Median(counts), steady,
                  steady > 0 ? 100 * shown / steady : 0, t_view, t_half, t_90);
    std::printf("%s\n", line);
    out << label << ",jump," << t0 << "," << frames << "," << Median(counts) << "," << steady << ","
        << (steady > 0 ? shown / steady : 0) << "," << t_half << "," << t_90 << ",,,," << t_view
        << "\n";
  }
  int refinements = 0;
  uint64_t bytes = 0;
  double complete_s = -1;
  for (const Received& r : f) {
    if (r.t <= pause_at) continue;
    refinements += r.refined;
    bytes += r.bytes;
    if (!r.partial) {
      complete_s = r.t - pause_at;
      std::printf(
          "pause at %.1f s: the complete frame (%u particles) in %.3f s, after %d "
          "refinements, %llu bytes\n",
          pause_at, r.count, complete_s, refinements, (unsigned long long)bytes);
      break;
    }
  }
  if (!completed) {
    std::printf("pause at %.1f s: no complete frame within %.0f s (%d refinements, %llu bytes)\n",
                pause_at, paused_end - pause_at, refinements, (unsigned long long)bytes);
  }
  out << label << ",pause," << pause_at << ",,,,,,," << complete_s << "," << refinements << ","
      << bytes << ",\n";
  return 0;  // a measurement, not a check: a pause that did not complete is a row too
}
