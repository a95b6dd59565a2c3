// What SPHERIC Test 2's probes cost against the step they follow: the scene's 14 probes (P1-P8
// wall pressures, H1-H4 column heights, the front, the kinetic energy) evaluated after every
// step, where the particles live (Simulation::EvaluateProbes: on a GPU a gather kernel that
// copies back only the values), and, for comparison, the way they were evaluated before: the
// whole state copied to the host and the probes computed there.
//
//   build/release/bench/probe_bench [--device cuda:0] [--spacings 0.02,0.01,0.00877]
//       [--steps 50] [--threads N] [--out bench/results]
//
// At 0.00877 m the scene holds about 1 M fluid particles. Each spacing warms up --steps steps,
// then times --steps steps alone and --steps steps each followed by the probes. Writes
// probe_cost_<device>.csv: device, spacing (m), particles, step_ms, probes_ms (on the device),
// host_probes_ms (state to the host, then the probes), share (probes_ms / step_ms).
#include <omp.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "dysa/core/device.h"
#include "dysa/core/probes.h"
#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"

namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}

struct Row {
  std::string device;
  double spacing = 0;
  size_t particles = 0;
  double step_ms = 0;
  double probes_ms = 0;
  double host_probes_ms = 0;
};

Row Measure(double spacing, const dysa::Device& device, int steps) {
  dysa::Scene scene = dysa::LoadScene("spheric_test2");
  dysa::SetParam(scene.params, "particle_spacing", spacing);
  dysa::Simulation sim(scene, device);
  Row row;
  row.device = sim.DeviceDescription();
  row.spacing = spacing;
  row.particles = sim.particle_count();
  const std::vector<dysa::ProbeSpec>& probes = sim.scene().probes;
  for (int i = 0; i < steps; ++i) sim.Step();

  auto start = Clock::now();
  for (int i = 0; i < steps; ++i) sim.Step();
  row.step_ms = 1e3 * Seconds(start) / steps;

  // Each probe evaluation follows a step, as in `dysa run` with probes every step; only the
  // evaluation is timed (the values are on the host when EvaluateProbes returns).
  double probe_s = 0;
  double checksum = 0;
  for (int i = 0; i < steps; ++i) {
    sim.Step();
    const auto t = Clock::now();
    const std::vector<double> values = sim.EvaluateProbes(probes);
    probe_s += Seconds(t);
    checksum += values.empty() ? 0 : values.front();
  }
  row.probes_ms = 1e3 * probe_s / steps;

  // Before: the whole state to the host (state() downloads it when a step has run on a GPU),
  // then the probes there.
  double host_s = 0;
  for (int i = 0; i < steps; ++i) {
    sim.Step();
    const auto t = Clock::now();
    const std::vector<double> values = dysa::EvaluateProbes(probes, sim.model(), sim.state());
    host_s += Seconds(t);
    checksum += values.empty() ? 0 : values.front();
  }
  row.host_probes_ms = 1e3 * host_s / steps;
  std::printf("  (P1 checksum %.3g Pa)\n", checksum);
  return row;
}

std::string FileSafe(std::string text) {
  for (char& c : text) {
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  }
  return text;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"The cost of SPHERIC Test 2's probes against the step"};
  std::string device_text = "cuda:0";
  std::vector<double> spacings = {0.02, 0.01, 0.00877};
  int steps = 50;
  int threads = 0;
  std::string out_dir = "bench/results";
  app.add_option("--device", device_text, "cpu, cuda or cuda:N")->capture_default_str();
  app.add_option("--spacings", spacings, "Particle spacings, m, comma separated")
      ->delimiter(',')
      ->check(CLI::Range(0.004, 0.1));
  app.add_option("--steps", steps, "Steps per measurement")->check(CLI::Range(1, 100000));
  app.add_option("--threads", threads, "CPU threads (0: all cores)")->check(CLI::Range(0, 1024));
  app.add_option("--out", out_dir, "Directory for the CSV")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  if (threads > 0) omp_set_num_threads(threads);

  dysa::Device device;
  try {
    device = dysa::ParseDevice(device_text);
    const std::string reason = dysa::DeviceUnavailableReason(device);
    if (!reason.empty()) {
      std::fprintf(stderr, "probe_bench: --device %s: %s\n", device_text.c_str(), reason.c_str());
      return 1;
    }
  } catch (const dysa::ConfigError& e) {
    std::fprintf(stderr, "probe_bench: %s\n", e.what());
    return 2;
  }

  std::vector<Row> rows;
  std::printf("%-10s %10s %10s %10s %12s %8s\n", "spacing_m", "particles", "step_ms", "probes_ms",
              "host_ms", "share");
  for (double spacing : spacings) {
    const Row r = Measure(spacing, device, steps);
    std::printf("%-10.5f %10zu %10.3f %10.3f %12.3f %7.2f%%\n", r.spacing, r.particles, r.step_ms,
                r.probes_ms, r.host_probes_ms, 100 * r.probes_ms / r.step_ms);
    rows.push_back(r);
  }
  std::filesystem::create_directories(out_dir);
  const std::string path =
      out_dir + "/probe_cost_" + (rows.empty() ? "none" : FileSafe(rows.front().device)) + ".csv";
  std::ofstream csv(path);
  csv << "device,spacing_m,particles,step_ms,probes_ms,host_probes_ms,share\n";
  for (const Row& r : rows) {
    csv << r.device << ',' << r.spacing << ',' << r.particles << ',' << r.step_ms << ','
        << r.probes_ms << ',' << r.host_probes_ms << ',' << r.probes_ms / r.step_ms << '\n';
  }
  std::printf("wrote %s\n", path.c_str());
  return 0;
}
