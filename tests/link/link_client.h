// The client side of the shaped-link cases (shaped_link_test.cc): one budgeted frame stream read
// as fast as it comes, and GetStatus polled beside it, for a set time; the figures of the time
// after a settling period. Runs in a forked child inside the link's namespace and reports its
// figures as "key value" lines, so the test process itself never starts gRPC.
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "frame_acknowledger.h"  // dysa_client's, the delivery signal the clients send
#include "soak/soak_client.h"

namespace dysa::testing {

struct LinkRun {
  std::string address;
  v1::StreamFramesRequest request;
  double settle_s = 4;   // figures start after this
  double measure_s = 6;  // and cover this long
};

// Figures by name; "error" (1) with "error_text" when the stream failed.
using LinkFigures = std::map<std::string, double>;

inline int64_t UnixMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

inline LinkFigures RunLinkClient(const LinkRun& run, std::string& error) {
  using Clock = std::chrono::steady_clock;
  LinkFigures f;
  auto stub = soak::Connect(run.address);
  auto status_stub = soak::Connect(run.address);
  if (!soak::WaitFor([&] { return soak::GetStatus(*status_stub, 1).has_value(); }, 20)) {
    error = "GetStatus did not answer within 20 s";
    return f;
  }
  const Clock::time_point start = Clock::now();
  const auto since = [&] { return soak::SecondsSince(start); };
  const double end_s = run.settle_s + run.measure_s;

  struct Sample {
    double detail, fps, bytes_per_s, age_s, link, particles, server_fps;
  };
  std::vector<Sample> samples;
  // The link rate while settling (printed, not checked): the highest, and when.
  double early_link_max = 0, early_link_max_at_s = 0;
  std::atomic<bool> done{false};
  std::thread poller([&] {
    while (!done && since() < end_s) {
      const auto status = soak::GetStatus(*status_stub, 2);
      if (since() < run.settle_s && status && status->streams_size() == 1 &&
          status->streams(0).link_bytes_per_second() > early_link_max) {
        early_link_max = status->streams(0).link_bytes_per_second();
        early_link_max_at_s = since();
      }
      if (since() >= run.settle_s && status && status->streams_size() == 1) {
        const auto& s = status->streams(0);
        samples.push_back({s.detail(), s.frames_per_second(), s.bytes_per_second(), s.age_s(),
                           s.link_bytes_per_second(), double(s.particles()),
                           status->frames_per_second()});
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
  });

  auto stream = soak::Subscribe(*stub, run.request);
  // With an ack token, every complete frame is reported as the client library reports it.
  std::unique_ptr<remote::FrameAcknowledger> acks;
  if (run.request.ack_token() != 0) {
    acks = std::make_unique<remote::FrameAcknowledger>(
        grpc::CreateChannel(run.address, grpc::InsecureChannelCredentials()),
        run.request.ack_token(), "");
  }
  int frames = 0;
  double bytes = 0, max_latency = 0, max_gap = 0, first_s = -1, last_s = -1;
  v1::FrameMessage last;
  while (since() < end_s) {
    if (!stream->ReadFrame(&last)) {
      error = "the stream ended: " + stream->Close().error_message();
      break;
    }
    if (acks) acks->FrameReceived();
    const double t = since();
    if (t < run.settle_s) continue;
    if (first_s >= 0) max_gap = std::max(max_gap, t - last_s);
    if (first_s < 0) first_s = t;
    last_s = t;
    ++frames;
    bytes += double(last.frame_bytes());
    max_latency = std::max(max_latency, double(UnixMicros() - last.produced_unix_us()) * 1e-6);
  }
  done = true;
  poller.join();
  if (error.empty()) stream->Close();

  const double window = last_s - first_s;
  f["client_frames"] = frames;
  f["client_fps"] = window > 0 ? (frames - 1) / window : 0;
  f["client_bytes_per_s"] = window > 0 ? bytes / (last_s - run.settle_s) : 0;
  f["client_latency_max_s"] = max_latency;
  f["client_gap_max_s"] = max_gap;
  f["status_samples"] = double(samples.size());
  f["settling_link_bytes_per_s_max"] = early_link_max;
  f["settling_link_bytes_per_s_max_at_s"] = early_link_max_at_s;
  if (samples.empty()) return f;
  const auto stat = [&](const std::string& name, double Sample::*field) {
    double lo = samples[0].*field, hi = lo, sum = 0;
    for (const Sample& s : samples) {
      lo = std::min(lo, s.*field), hi = std::max(hi, s.*field), sum += s.*field;
    }
    f[name + "_min"] = lo;
    f[name + "_max"] = hi;
    f[name + "_mean"] = sum / double(samples.size());
  };
  stat("status_detail", &Sample::detail);
  stat("status_fps", &Sample::fps);
  stat("status_bytes_per_s", &Sample::bytes_per_s);
  stat("status_age_s", &Sample::age_s);
  stat("status_link_bytes_per_s", &Sample::link);
  stat("status_particles", &Sample::particles);
  stat("server_fps", &Sample::server_fps);
  return f;
}

inline std::string FormatFigures(const LinkFigures& figures) {
  std::ostringstream out;
  out.precision(6);
  for (const auto& [name, value] : figures) out << name << ' ' << value << '\n';
  return out.str();
}

inline LinkFigures ParseFigures(const std::string& text) {
  LinkFigures figures;
  std::istringstream in(text);
  std::string name;
  double value = 0;
  while (in >> name >> value) figures[name] = value;
  return figures;
}

}  // namespace dysa::testing
