// Part 3: the thesis scene at 60 frames/s with one subscriber that never reads and one that does:
// resident memory of the whole process, sampled every second.
#include <algorithm>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "server_bench/server_bench.h"

namespace server_bench {

void Stalled(double seconds, const dysa::Device& device, const std::filesystem::path& out) {
  HostOptions options;
  options.frame_rate = 60;
  options.device = device;
  SimulationHost host(dysa::LoadScene("seed_test_scene"), options);
  Server server(host, Loopback());
  Client stalled(Address(server), 0, Mode::kStalled);
  Client reader(Address(server), 1, Mode::kDecode);
  std::ofstream csv(out);
  csv << "seconds,rss_mib,history_mib,frame,frames_encoded,frames_alive,reader_frames\n";
  const auto start = Clock::now();
  // Memory apart from the step-back history, which grows to its budget by design.
  double first = 0, peak = 0;
  for (int s = 0; s <= int(seconds); ++s) {
    std::this_thread::sleep_until(start + std::chrono::seconds(s));
    const auto status = host.Status();
    const double rss = RssMiB();
    const double other = rss - status.history_bytes / 1048576.0;
    if (s == 5) first = other;
    peak = std::max(peak, other);
    csv << s << "," << rss << "," << status.history_bytes / 1048576.0 << "," << status.frame << ","
        << status.frames_encoded << "," << host.hub().frames_alive() << "," << reader.frames
        << "\n";
    std::printf(
        "stalled   t=%3d s  rss %7.1f MiB  history %6.1f MiB  frame %6llu  frames alive %lld  "
        "reader %llu\n",
        s, rss, status.history_bytes / 1048576.0, (unsigned long long)status.frame,
        (long long)host.hub().frames_alive(), (unsigned long long)reader.frames.load());
    std::fflush(stdout);
  }
  std::printf("stalled   rss less history: at 5 s %.1f MiB, peak %.1f MiB (growth %.1f MiB)\n",
              first, peak, peak - first);
  server.Shutdown();
}

}  // namespace server_bench
