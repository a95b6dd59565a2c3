// What a particle budget costs and what it shows (issue 32, item 7). Two halves, driven by
// bench/remote_view_bench.sh, which renders the screenshots in between:
//
//   remote_view_bench bytes --scene FILE --frames N [--percent 100,30,10,3,1]
//       Steps the scene N frames (bit for bit the frame a server shows after `dysa step N`),
//       then encodes that frame (a keyframe) and the next --deltas frames (delta frames) at the
//       detail a particle budget of each percentage gets (the server's ladder, DetailController),
//       and at the detail a --link-mbit link (100) holds at --fps frames/s. Prints one CSV row per
//       detail: bytes per keyframe and delta frame, frames/s at 100 Mbit/s and 1 Gbit/s, and the
//       particle budget that gets this detail (what the script asks the viewer for).
//
//   remote_view_bench compare --reference FULL.png --csv IN.csv --images a.png,b.png,...
//       --out OUT.csv --sheet SHEET.png
//       SSIM and the largest screen gap of each image against the full-detail one (view_error.h),
//       appended to the rows of IN.csv (same order), and a contact sheet of the images.
#include <omp.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "dysa/codec/detail_subset.h"
#include "dysa/codec/frame_codec.h"
#include "dysa/core/simulation.h"
#include "dysa/service/detail_controller.h"
#include "dysa/service/frame_publisher.h"
#include "view_error.h"

namespace {

struct Captured {
  std::array<double, 3> lo{}, hi{};
  uint64_t step = 0;
  double time = 0;
  std::vector<float> positions, velocities;
};

Captured Capture(const dysa::Simulation& sim) {
  Captured c;
  const dysa::Aabb& domain = sim.model().domain;
  for (int a = 0; a < 3; ++a) c.lo[a] = domain.min[a], c.hi[a] = domain.max[a];
  c.step = sim.step();
  c.time = sim.time();
  c.positions.resize(3 * sim.particle_count());
  c.velocities.resize(3 * sim.particle_count());
  sim.ReadParticlesById({c.positions, c.velocities, {}});
  return c;
}

struct Row {
  std::string label;
  int level = 0;
};

// The ladder level the server gives a stream whose particle budget is `budget`.
int BudgetLevel(uint64_t budget, uint32_t total) {
  dysa::service::DetailBudget b;
  b.particles_per_frame = budget;
  dysa::service::DetailController controller(b);
  controller.SetTotal(0, total);
  return controller.level();
}

int Bytes(const std::string& scene_path, int frames, int deltas, const std::string& percents,
          double fps, double link_mbit, int threads) {
  omp_set_num_threads(threads);
  dysa::Simulation sim(dysa::LoadScene(scene_path));
  const auto total = uint32_t(sim.particle_count());
  std::fprintf(stderr, "remote_view_bench: %u particles, stepping %d frames ...\n", total, frames);
  for (int f = 0; f < frames; ++f) sim.StepFrame();
  std::vector<Captured> seq;
  for (int f = 0; f <= deltas; ++f) {
    seq.push_back(Capture(sim));
    if (f < deltas) sim.StepFrame();
  }

  auto encode = [&](int level) {
    dysa::codec::StreamConfig config;    // the viewer's stream: positions + speed, 16/8 bits
    config.keyframe_interval = 1000000;  // one keyframe, then deltas
    config.detail_threshold =
        level == 0
            ? 0
            : dysa::codec::DetailThreshold(dysa::service::DetailController::LevelFraction(level));
    dysa::codec::FrameEncoder encoder(config);
    size_t key = 0, delta = 0;
    uint32_t count = 0;
    for (size_t f = 0; f < seq.size(); ++f) {
      dysa::codec::FrameInput in;
      in.step = seq[f].step;
      in.time = seq[f].time;
      in.domain_min = seq[f].lo;
      in.domain_max = seq[f].hi;
      in.positions = seq[f].positions;
      in.velocities = seq[f].velocities;
      size_t bytes = 0;
      for (const auto& chunk : encoder.Encode(in)) bytes += chunk.size();
      (f == 0 ? key : delta) += bytes;
      count = encoder.last_count();
    }
    return std::tuple{key, deltas > 0 ? double(delta) / deltas : double(key), count};
  };

  std::vector<Row> rows;
  std::stringstream list(percents);
  for (std::string item; std::getline(list, item, ',');) {
    const double percent = std::stod(item);
    if (!(percent > 0 && percent <= 100)) {
      std::fprintf(stderr, "remote_view_bench: --percent: %s outside (0, 100]\n", item.c_str());
      return 2;
    }
    rows.push_back({item + "%", BudgetLevel(uint64_t(std::ceil(percent / 100 * total)), total)});
  }
  // The detail a link of `link_mbit` holds at `fps`: the largest fraction on the ladder whose
  // delta frames fit its bytes per second (the controller's rule, with the measured cost instead
  // of its estimate).
  const double link = link_mbit * 1e6 / 8;
  int fit = 0;
  while (fit + 1 < dysa::service::DetailController::kLevels &&
         std::get<1>(encode(fit)) * fps > link) {
    ++fit;
  }
  rows.push_back(
      {std::to_string(int(link_mbit)) + "Mbit@" + std::to_string(int(fps)) + "fps", fit});

  std::printf(
      "budget,fraction,particles,particle_budget,keyframe_bytes,delta_bytes,delta_bytes_per_"
      "particle,fps_100mbit,fps_1gbit\n");
  for (const Row& r : rows) {
    const auto [key, delta, count] = encode(r.level);
    const double fraction = dysa::service::DetailController::LevelFraction(r.level);
    std::printf("%s,%.5f,%u,%llu,%zu,%.0f,%.3f,%.1f,%.1f\n", r.label.c_str(), fraction, count,
                (unsigned long long)std::ceil(fraction * total), key, delta,
                count ? delta / count : 0.0, 100e6 / 8 / delta, 1e9 / 8 / delta);
  }
  return 0;
}

// The server's cost of one watched frame per detail: copying the particles out of the solver
// (GatherSnapshot, which on the CPU copies only those of the widest detail subscribed) and
// encoding them, the median of `repeats` frames (the encoder warmed up on one first).
int Gather(const std::string& scene_path, const std::string& percents, int repeats, int threads) {
  omp_set_num_threads(threads);
  dysa::Simulation sim(dysa::LoadScene(scene_path));
  sim.StepFrame();  // storage in cell order, as while running
  const auto total = uint32_t(sim.particle_count());
  std::printf("percent,fraction,particles,gather_ms,encode_ms\n");
  std::stringstream list(percents);
  for (std::string item; std::getline(list, item, ',');) {
    const double percent = std::stod(item);
    const int level = BudgetLevel(uint64_t(std::ceil(percent / 100 * total)), total);
    const double fraction = dysa::service::DetailController::LevelFraction(level);
    const uint32_t threshold = level == 0 ? 0 : dysa::codec::DetailThreshold(fraction);
    dysa::codec::StreamConfig config;
    config.detail_threshold = threshold;
    config.keyframe_interval = 1;  // the same work every frame
    dysa::codec::FrameEncoder encoder(config);
    dysa::service::FrameSnapshot snapshot;
    std::vector<double> gather_ms, encode_ms;
    for (int r = 0; r <= repeats; ++r) {
      const auto t0 = std::chrono::steady_clock::now();
      dysa::service::GatherSnapshot(sim, config.fields, threshold, snapshot);
      const auto t1 = std::chrono::steady_clock::now();
      dysa::codec::FrameInput in;
      in.domain_min = snapshot.domain_min;
      in.domain_max = snapshot.domain_max;
      in.positions = snapshot.positions;
      in.velocities = snapshot.velocities;
      encoder.Encode(in);
      const auto t2 = std::chrono::steady_clock::now();
      if (r == 0) continue;  // warm-up: buffers sized, the kept ids listed once
      gather_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
      encode_ms.push_back(std::chrono::duration<double, std::milli>(t2 - t1).count());
    }
    auto median = [](std::vector<double> v) {
      std::nth_element(v.begin(), v.begin() + long(v.size() / 2), v.end());
      return v[v.size() / 2];
    };
    std::printf("%s,%.5f,%u,%.2f,%.2f\n", item.c_str(), fraction, encoder.last_count(),
                median(gather_ms), median(encode_ms));
  }
  return 0;
}

std::vector<std::string> Split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string item; std::getline(in, item, ',');) out.push_back(item);
  return out;
}

int Compare(const std::string& reference_path, const std::string& csv_in, const std::string& images,
            const std::string& csv_out, const std::string& sheet) {
  const dysa::bench::Image reference = dysa::bench::ReadPng(reference_path);
  std::ifstream in(csv_in);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  const std::vector<std::string> paths = Split(images);
  if (lines.size() != paths.size() + 1) {
    std::fprintf(stderr, "remote_view_bench: %s has %zu rows for %zu images\n", csv_in.c_str(),
                 lines.size() - 1, paths.size());
    return 2;
  }
  std::ofstream out(csv_out);
  out << lines[0] << ",ssim,ssim_drawn,ssim_drawn_coarse,largest_gap_px,drawn_px,drawn_px_full\n";
  std::vector<dysa::bench::Image> shown;
  for (size_t i = 0; i < paths.size(); ++i) {
    shown.push_back(dysa::bench::ReadPng(paths[i]));
    const dysa::bench::ViewError e = dysa::bench::CompareViews(reference, shown.back());
    out << lines[i + 1] << "," << e.ssim << "," << e.ssim_drawn << "," << e.ssim_drawn_coarse << ","
        << e.largest_gap_px << "," << e.drawn_image << "," << e.drawn_reference << "\n";
  }
  dysa::bench::WritePng(sheet, dysa::bench::ContactSheet(shown, 3));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Bytes, frame rate and image error of budgeted streams (issue 32, item 7)"};
  app.require_subcommand(1);

  std::string scene;
  int frames = 24, deltas = 3, threads = 2;
  std::string percents = "100,30,10,3,1";
  double fps = 30, link_mbit = 100;
  auto* bytes = app.add_subcommand("bytes", "Bytes per frame at each detail (CSV on stdout)");
  bytes->add_option("--scene", scene, "Scene file (JSON)")->required()->check(CLI::ExistingFile);
  bytes->add_option("--frames", frames, "Frames stepped before the compared one")
      ->check(CLI::Range(0, 100000))
      ->capture_default_str();
  bytes->add_option("--deltas", deltas, "Delta frames encoded after it")
      ->check(CLI::Range(0, 100))
      ->capture_default_str();
  bytes->add_option("--percent", percents, "Particle budgets, percent of the scene")
      ->capture_default_str();
  bytes->add_option("--fps", fps, "Frame rate the link's row holds")
      ->check(CLI::Range(1.0, 1000.0))
      ->capture_default_str();
  bytes->add_option("--link-mbit", link_mbit, "The link of that row, Mbit/s")
      ->check(CLI::Range(1.0, 100000.0))
      ->capture_default_str();
  bytes->add_option("--threads", threads, "OpenMP threads")
      ->check(CLI::Range(1, 1024))
      ->capture_default_str();

  int repeats = 7;
  auto* gather = app.add_subcommand("gather", "Server cost of a frame at each detail (CSV)");
  gather->add_option("--scene", scene, "Scene file (JSON)")->required()->check(CLI::ExistingFile);
  gather->add_option("--percent", percents, "Particle budgets, percent of the scene")
      ->capture_default_str();
  gather->add_option("--repeats", repeats, "Frames timed per detail (the median is printed)")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  gather->add_option("--threads", threads, "OpenMP threads")
      ->check(CLI::Range(1, 1024))
      ->capture_default_str();

  std::string reference, csv_in, images, csv_out, sheet;
  auto* compare = app.add_subcommand("compare", "Image error against the full-detail image");
  compare->add_option("--reference", reference, "Full-detail PNG")->required();
  compare->add_option("--csv", csv_in, "Rows from `bytes`, one per image")->required();
  compare->add_option("--images", images, "PNGs, comma-separated, in the rows' order")->required();
  compare->add_option("--out", csv_out, "CSV to write")->required();
  compare->add_option("--sheet", sheet, "Contact sheet PNG to write")->required();
  CLI11_PARSE(app, argc, argv);

  try {
    if (*bytes) return Bytes(scene, frames, deltas, percents, fps, link_mbit, threads);
    if (*gather) return Gather(scene, percents, repeats, threads);
    return Compare(reference, csv_in, images, csv_out, sheet);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "remote_view_bench: %s\n", e.what());
    return 1;
  }
}
