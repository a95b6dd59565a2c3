// View-dependent detail (docs/server.md, "View-dependent detail"): what a camera buys a budget.
// For a block of fluid and a camera that sees part of it, per particle count and budget: the
// time to order and select the view subset, the share of the kept particles that are in view
// against the share of all, the bytes of the view subset's keyframe and of a delta frame, and the
// progressive completion while paused (refinements and their bytes) against one full keyframe.
// Prints a table and writes bench/results/view_detail.csv.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "dysa/service/frame_hub.h"
#include "dysa/service/view_detail.h"

namespace {

using dysa::service::FrameHub;
using dysa::service::FrameSnapshot;
using dysa::service::StreamView;
using Clock = std::chrono::steady_clock;

class Listener : public dysa::service::FrameListener {
 public:
  void OnFrameReady() override {}
  void OnHubClosed() override {}
};

// n particles in the lower half of the [-1, 1]^3 domain (a settled pool), frame f moved a little.
FrameSnapshot Pool(size_t n, uint64_t frame) {
  FrameSnapshot s;
  s.frame = frame;
  s.step = 10 * frame;
  s.domain_min = {-1, -1, -1};
  s.domain_max = {1, 1, 1};
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(0, 1);
  s.positions.resize(3 * n);
  s.velocities.resize(3 * n);
  for (size_t i = 0; i < n; ++i) {
    const float x = -0.99f + 1.98f * u(rng), y = -0.99f + 0.98f * u(rng);
    const float z = -0.99f + 1.98f * u(rng);
    s.positions[3 * i] = x + 1e-3f * float(frame) * std::sin(3 * z);
    s.positions[3 * i + 1] = y;
    s.positions[3 * i + 2] = z;
    s.velocities[3 * i] = 0.06f * std::sin(3 * z);
    s.velocities[3 * i + 1] = 0;
    s.velocities[3 * i + 2] = 0;
  }
  return s;
}

// Close above the pool, looking down into it: a patch of its water fills the view, the rest of
// the pool is out of it.
StreamView Camera() {
  StreamView v;
  v.eye = {0.5, 0.1, 0.5};
  v.target = {0.4, -0.9, 0.3};
  v.fov_y_deg = 45;
  v.aspect = 16.0 / 9;
  return v;
}

struct Row {
  size_t n = 0;
  double fraction = 0;
  double select_ms = 0;
  double in_view_all = 0, in_view_kept = 0;
  size_t base_bytes = 0, delta_bytes = 0, completion_bytes = 0, full_key_bytes = 0;
  int refinements = 0;
};

Row Measure(size_t n, double fraction) {
  Row r;
  r.n = n;
  r.fraction = fraction;
  const uint64_t budget = std::max<uint64_t>(1, uint64_t(fraction * double(n)));
  const FrameSnapshot a = Pool(n, 1), b = Pool(n, 2);
  std::vector<double> times;
  std::vector<uint32_t> kept;
  for (int rep = 0; rep < 3; ++rep) {
    const auto start = Clock::now();
    const dysa::service::ViewOrder order(Camera(), a.positions, a.domain_min, a.domain_max, 1);
    kept = order.Select(budget);
    times.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
    if (rep == 0) {
      size_t all = 0, in = 0;
      for (uint32_t id = 0; id < n; ++id) all += order.InView(id);
      for (uint32_t id : kept) in += order.InView(id);
      r.in_view_all = double(all) / double(n);
      r.in_view_kept = double(in) / double(kept.size());
    }
  }
  std::sort(times.begin(), times.end());
  r.select_ms = times[1];

  FrameHub hub(4);
  Listener l, plain_listener;
  dysa::service::SubscriptionOptions o;
  o.budget.particles_per_frame = budget;
  auto s = hub.Subscribe(o, &l);
  auto plain = hub.Subscribe({}, &plain_listener);
  hub.SetStreamView(s->id(), Camera());
  hub.Publish(a, true, false);
  r.full_key_bytes = plain->Take(nullptr)->bytes;
  r.base_bytes = s->Take(nullptr)->bytes;
  hub.Publish(b, true, false);
  plain->Take(nullptr);
  auto frame = s->Take(nullptr);
  r.delta_bytes = frame->bytes;
  while (frame->partial && r.refinements < 64) {
    hub.BytesDelivered(s, dysa::service::SteadySeconds(), frame->bytes, true);
    hub.Publish(b, true, false);
    frame = s->Take(nullptr);
    r.completion_bytes += frame->bytes;
    ++r.refinements;
  }
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"View-dependent detail: selection cost, in-view share, bytes, completion"};
  std::vector<size_t> sizes = {100000, 1000000};
  std::vector<double> fractions = {0.01, 0.1};
  std::string out = "bench/results/view_detail.csv";
  app.add_option("--particles", sizes, "Particle counts");
  app.add_option("--fractions", fractions, "Budgets as fractions of the particles, (0, 1]");
  app.add_option("--out", out, "CSV file");
  CLI11_PARSE(app, argc, argv);

  std::filesystem::create_directories(std::filesystem::path(out).parent_path());
  std::ofstream csv(out);
  csv << "particles,budget_fraction,select_ms,in_view_share_all,in_view_share_kept,"
         "view_keyframe_bytes,view_delta_bytes,refinements,completion_bytes,full_keyframe_bytes\n";
  std::printf("%10s %7s %10s %9s %10s %11s %10s %5s %13s %12s\n", "particles", "budget",
              "select ms", "view/all", "view/kept", "key bytes", "delta B", "refs", "complete B",
              "full key B");
  for (size_t n : sizes) {
    for (double f : fractions) {
      const Row r = Measure(n, f);
      std::printf("%10zu %7.3f %10.2f %9.3f %10.3f %11zu %10zu %5d %13zu %12zu\n", r.n, r.fraction,
                  r.select_ms, r.in_view_all, r.in_view_kept, r.base_bytes, r.delta_bytes,
                  r.refinements, r.completion_bytes, r.full_key_bytes);
      csv << r.n << ',' << r.fraction << ',' << r.select_ms << ',' << r.in_view_all << ','
          << r.in_view_kept << ',' << r.base_bytes << ',' << r.delta_bytes << ',' << r.refinements
          << ',' << r.completion_bytes << ',' << r.full_key_bytes << '\n';
    }
  }
  return 0;
}
