// Frame codec on frames from real runs: bytes per particle and encode/decode time for keyframes
// and delta frames, for every field combination. Writes bench/results/codec.csv.
//
//   build/release/bench/codec_bench [--threads 2] [--frames 8] [--large-per-axis 100]
//
// Frames: the thesis's 91,125-particle scene at 1 s of simulated time (the splash, the hardest
// case for prediction) and at 5 s (the fluid sloshing in the box), consecutive frames
// (iterations_per_frame steps apart, as a viewer sees them); and a block of 100^3 = 1,000,000
// particles of the thesis fluid falling in a larger box.
#include <omp.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>

#include "dysa/codec/frame_codec.h"
#include "dysa/core/simulation.h"

namespace {

using Clock = std::chrono::steady_clock;
using dysa::codec::Field;

// One frame in id order, as the server will hand it to the encoder.
struct CapturedFrame {
  uint64_t step;
  double time;
  std::vector<float> positions, velocities, densities;
};

CapturedFrame Capture(const dysa::Simulation& sim) {
  const dysa::ParticleArrays& p = sim.state().particles;
  CapturedFrame f{sim.step(), sim.time(), {}, {}, {}};
  f.positions.resize(3 * p.size());
  f.velocities.resize(3 * p.size());
  f.densities.resize(p.size());
  for (size_t i = 0; i < p.size(); ++i) {
    const uint32_t id = p.id[i];
    for (int a = 0; a < 3; ++a) {
      f.positions[3 * id + a] = p.position[i][a];
      f.velocities[3 * id + a] = p.velocity[i][a];
    }
    f.densities[id] = p.density[i];
  }
  return f;
}

std::vector<CapturedFrame> Record(dysa::Scene scene, double warmup_s, int frames) {
  dysa::Simulation sim(std::move(scene));
  while (sim.time() < warmup_s) sim.Step();
  std::vector<CapturedFrame> out;
  for (int f = 0; f < frames; ++f) {
    sim.StepFrame();
    out.push_back(Capture(sim));
  }
  return out;
}

struct Combo {
  const char* name;
  uint32_t fields;
  dysa::codec::VelocityEncoding velocity_encoding = dysa::codec::VelocityEncoding::kComponents;
};

double Ms(Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); }

// Order-0 entropy (bits per value) of the residuals of 16-bit positions quantised over the
// domain, for the last frame of the sequence predicted with constant velocity (from 2 frames)
// and constant acceleration (from 3): a lower bound for any coder of those residuals.
std::pair<double, double> PositionResidualEntropy(const std::vector<CapturedFrame>& frames,
                                                  const dysa::Aabb& domain) {
  const size_t last = frames.size() - 1;
  auto q = [&](size_t f, size_t i) {
    const int a = int(i % 3);
    const double t = (frames[f].positions[i] - domain.min[a]) / (domain.max[a] - domain.min[a]);
    return std::llround(t * 65535.0);
  };
  std::map<long long, size_t> linear, quadratic;
  const size_t n = frames[last].positions.size();
  for (size_t i = 0; i < n; ++i) {
    const long long a = q(last - 1, i), b = q(last - 2, i), c = q(last - 3, i);
    ++linear[q(last, i) - (2 * a - b)];
    ++quadratic[q(last, i) - (3 * (a - b) + c)];
  }
  auto entropy = [&](const std::map<long long, size_t>& histogram) {
    double bits = 0;
    for (const auto& [value, count] : histogram) {
      const double p = double(count) / double(n);
      bits -= p * std::log2(p);
    }
    return bits;
  };
  return {entropy(linear), entropy(quadratic)};
}

// The constant-acceleration residuals again, each taken against the residual of the particle
// before it in the cell order (cells of edge `cell`) of the previous frame, which a decoder
// has: if neighbouring particles' residuals were alike, this entropy would be lower.
double SpatialResidualEntropy(const std::vector<CapturedFrame>& frames, const dysa::Aabb& domain,
                              double cell) {
  const size_t last = frames.size() - 1;
  const size_t n = frames[last].densities.size();
  auto q = [&](size_t f, size_t i) {
    const int a = int(i % 3);
    const double t = (frames[f].positions[i] - domain.min[a]) / (domain.max[a] - domain.min[a]);
    return std::llround(t * 65535.0);
  };
  std::vector<std::pair<int64_t, uint32_t>> order(n);
  for (size_t i = 0; i < n; ++i) {
    int64_t key = 0;
    for (int a = 0; a < 3; ++a) {
      key = key * 4096 + int64_t((frames[last - 1].positions[3 * i + a] - domain.min[a]) / cell);
    }
    order[i] = {key, uint32_t(i)};
  }
  std::sort(order.begin(), order.end());
  std::map<long long, size_t> histogram;
  for (int a = 0; a < 3; ++a) {
    long long previous = 0;
    for (const auto& [key, i] : order) {
      const size_t v = 3 * size_t(i) + a;
      const long long r = q(last, v) - (3 * (q(last - 1, v) - q(last - 2, v)) + q(last - 3, v));
      ++histogram[r - previous];
      previous = r;
    }
  }
  double bits = 0;
  for (const auto& [value, count] : histogram) {
    const double p = double(count) / double(3 * n);
    bits -= p * std::log2(p);
  }
  return bits;
}

// The same for 8-bit speed over [0, 1.25 max] of the first frame (the encoder's keyframe range),
// constant acceleration: with the positions' figure, the order-0 size of a positions + speed
// delta frame, (3 H_position + H_speed) / 8 bytes per particle.
double SpeedResidualEntropy(const std::vector<CapturedFrame>& frames) {
  auto speed = [&](size_t f, size_t i) {
    const float* v = frames[f].velocities.data() + 3 * i;
    return std::sqrt(double(v[0]) * v[0] + double(v[1]) * v[1] + double(v[2]) * v[2]);
  };
  const size_t n = frames.front().densities.size();
  double top = 1e-3;
  for (size_t i = 0; i < n; ++i) top = std::max(top, 1.25 * speed(0, i));
  const size_t last = frames.size() - 1;
  auto q = [&](size_t f, size_t i) { return std::llround(speed(f, i) / top * 255.0); };
  std::map<long long, size_t> histogram;
  for (size_t i = 0; i < n; ++i) {
    const long long a = q(last - 1, i), b = q(last - 2, i), c = q(last - 3, i);
    ++histogram[q(last, i) - std::clamp(3 * (a - b) + c, 0LL, 255LL)];
  }
  double bits = 0;
  for (const auto& [value, count] : histogram) {
    const double p = double(count) / double(n);
    bits -= p * std::log2(p);
  }
  return bits;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Frame codec: bytes per particle and speed on frames from real runs"};
  int threads = 2;
  int frames = 8;
  int large_per_axis = 100;
  std::string out_dir = "bench/results";
  app.add_option("--threads", threads, "OpenMP threads")
      ->check(CLI::Range(1, 1024))
      ->capture_default_str();
  app.add_option("--frames", frames, "Frames per sequence (1 keyframe + deltas)")
      ->check(CLI::Range(2, 1000))
      ->capture_default_str();
  app.add_option("--large-per-axis", large_per_axis, "Particles per axis of the large block")
      ->check(CLI::Range(10, 200))
      ->capture_default_str();
  app.add_option("--out", out_dir, "Directory for codec.csv")->capture_default_str();
  uint32_t chunk_particles = dysa::codec::StreamConfig{}.chunk_particles;
  app.add_option("--chunk-particles", chunk_particles, "Particles per chunk")
      ->check(CLI::Range(1u, 1u << 20))
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  omp_set_num_threads(threads);
  struct Sequence {
    std::string name;
    dysa::Scene scene;
    std::vector<CapturedFrame> frames;
  };
  std::vector<Sequence> sequences;
  {
    dysa::Scene thesis = dysa::LoadScene("seed_test_scene");
    std::printf("recording %d frames of %s ...\n", frames, thesis.name.c_str());
    sequences.push_back({"thesis_t1s", thesis, Record(thesis, 1.0, frames)});
    sequences.push_back({"thesis_t5s", thesis, Record(thesis, 5.0, frames)});
    // A large block of the thesis fluid: the same particle spacing (5 m / 44) and parameters,
    // 100^3 particles in a box scaled to match.
    dysa::Scene large = thesis;
    const double size = 5.0 / 44 * (large_per_axis - 1);
    large.domain = {dysa::Vec3d::Constant(-size), dysa::Vec3d::Constant(size)};
    large.params.particle_quantity = large_per_axis;
    large.params.spawn_size = size;
    std::printf("recording %d frames of a %d^3 block ...\n", frames, large_per_axis);
    sequences.push_back(
        {"block_" + std::to_string(large_per_axis) + "^3", large, Record(large, 0.3, frames)});
  }

  const std::vector<Combo> combos = {
      {"positions", Field::kPositions},
      {"positions+speed", Field::kPositions | Field::kSpeed},
      {"positions+velocity", Field::kPositions | Field::kVelocity},
      {"positions+velocity(oct)", Field::kPositions | Field::kVelocity,
       dysa::codec::VelocityEncoding::kOctahedral},
      {"positions+density", Field::kPositions | Field::kDensity},
      {"all", Field::kPositions | Field::kSpeed | Field::kVelocity | Field::kDensity},
  };
  std::filesystem::create_directories(out_dir);
  std::ofstream csv(std::filesystem::path(out_dir) / "codec.csv");
  csv << "sequence,particles,fields,threads,kind,bytes_per_particle,encode_ms,decode_ms,"
         "position_error_m,velocity_error_mps,velocity_bound_mps,max_chunk_bytes\n";
  std::printf("\n%-18s %-24s %8s %11s %11s %11s %11s %11s\n", "frames", "fields", "kind",
              "B/particle", "encode ms", "decode ms", "max error", "max v err");
  for (const Sequence& seq : sequences) {
    const size_t n = seq.frames.front().densities.size();
    for (const Combo& combo : combos) {
      dysa::codec::StreamConfig config;
      config.fields = combo.fields;
      config.velocity_encoding = combo.velocity_encoding;
      config.keyframe_interval = 1000000;  // one keyframe, then deltas
      config.chunk_particles = chunk_particles;
      dysa::codec::FrameEncoder encoder(config);
      dysa::codec::FrameDecoder decoder;
      dysa::codec::Frame decoded_frame;  // reused: the decoder recycles its buffers
      // kind 0: keyframe, 1: deltas (averaged)
      double bytes[2] = {0, 0}, enc[2] = {0, 0}, dec[2] = {0, 0};
      int counts[2] = {0, 0};
      size_t max_chunk = 0;
      double max_error = 0, max_velocity_error = 0, velocity_bound = 0;
      // Two passes over the sequence: the first warms the encoder and decoder up (their buffers
      // are allocated once per stream), the second, which starts with a requested keyframe as
      // after a reset, is measured: the steady state of a long-running stream.
      for (int pass = 0; pass < 2; ++pass)
        for (const CapturedFrame& f : seq.frames) {
          if (pass == 1 && &f == &seq.frames.front()) encoder.RequestKeyframe();
          dysa::codec::FrameInput in;
          in.step = f.step;
          in.time = f.time;
          for (int a = 0; a < 3; ++a) {
            in.domain_min[a] = seq.scene.domain.min[a];
            in.domain_max[a] = seq.scene.domain.max[a];
          }
          in.positions = f.positions;
          in.velocities = f.velocities;
          in.densities = f.densities;
          const auto t0 = Clock::now();
          const std::vector<dysa::codec::Chunk> chunks = encoder.Encode(in);
          const auto t1 = Clock::now();
          const bool decoded = decoder.AddChunks(chunks, decoded_frame);
          const auto t2 = Clock::now();
          const dysa::codec::Frame* frame = &decoded_frame;
          if (!decoded) {
            std::fprintf(stderr, "codec_bench: a frame did not decode\n");
            return 1;
          }
          if (pass == 0) continue;
          const int kind = frame->keyframe ? 0 : 1;
          size_t total = 0;
          for (const auto& c : chunks) total += c.size(), max_chunk = std::max(max_chunk, c.size());
          bytes[kind] += double(total) / double(n);
          enc[kind] += Ms(t1 - t0);
          dec[kind] += Ms(t2 - t1);
          ++counts[kind];
          // Check the bound on every value, as the tests do.
          for (size_t i = 0; i < 3 * n; ++i) {
            const double err = std::abs(double(frame->positions[i]) - f.positions[i]);
            if (err > frame->position_error[i % 3]) {
              std::fprintf(stderr, "codec_bench: error %g beyond the bound\n", err);
              return 1;
            }
            max_error = std::max(max_error, err);
          }
          if (frame->fields & Field::kVelocity) {
            for (size_t i = 0; i < 3 * n; ++i) {
              const double err = std::abs(double(frame->velocities[i]) - f.velocities[i]);
              if (err > frame->velocity_error) {
                std::fprintf(stderr, "codec_bench: velocity error %g beyond the bound\n", err);
                return 1;
              }
              max_velocity_error = std::max(max_velocity_error, err);
            }
            velocity_bound = std::max(velocity_bound, frame->velocity_error);
          }
        }
      for (int kind = 0; kind < 2; ++kind) {
        if (counts[kind] == 0) continue;
        const char* kind_name = kind == 0 ? "keyframe" : "delta";
        const double b = bytes[kind] / counts[kind], e = enc[kind] / counts[kind],
                     d = dec[kind] / counts[kind];
        std::printf("%-18s %-24s %8s %11.3f %11.2f %11.2f %11.2e %11.2e\n", seq.name.c_str(),
                    combo.name, kind_name, b, e, d, max_error, max_velocity_error);
        csv << seq.name << ',' << n << ',' << combo.name << ',' << threads << ',' << kind_name
            << ',' << b << ',' << e << ',' << d << ',' << max_error << ',' << max_velocity_error
            << ',' << velocity_bound << ',' << max_chunk << '\n';
      }
    }
  }
  std::printf("\norder-0 entropy of 16-bit position residuals, bits per axis (the last frame):\n");
  for (const Sequence& seq : sequences) {
    const auto [linear, quadratic] = PositionResidualEntropy(seq.frames, seq.scene.domain);
    const double speed = SpeedResidualEntropy(seq.frames);
    const double spatial =
        SpatialResidualEntropy(seq.frames, seq.scene.domain, seq.scene.params.smoothing_radius);
    std::printf(
        "  %-18s constant velocity %.2f, constant acceleration %.2f (against the previous "
        "particle's in cell order %.2f); 8-bit speed %.2f: positions + speed deltas need >= "
        "%.2f B/particle at order 0\n",
        seq.name.c_str(), linear, quadratic, spatial, speed, (3 * quadratic + speed) / 8);
  }
  std::printf("\nwrote %s/codec.csv\n", out_dir.c_str());
  return 0;
}
