#include "run_command.h"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <ostream>
#include <sstream>

#include "dysa/core/probes.h"
#include "dysa/core/simulation.h"
#include "probe_writer.h"
#include "vtk_writer.h"

namespace dysa {
namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

// Shortest readable form: 1.5, not 1.500000.
std::string Number(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

void PrintProfile(const Simulation& sim, double wall_s, uint64_t steps, int threads,
                  std::ostream& out) {
  double total_ms = 0;
  for (const PassProfile& pass : sim.profile()) total_ms += pass.total_ms;
  out << "\n"
      << std::left << std::setw(18) << "pass" << std::right << std::setw(12) << "ms/step"
      << std::setw(10) << "share\n";
  for (const PassProfile& pass : sim.profile()) {
    const double per_step = steps ? pass.total_ms / double(steps) : 0.0;
    out << std::left << std::setw(18) << pass.name << std::right << std::fixed
        << std::setprecision(3) << std::setw(12) << per_step << std::setw(9) << std::setprecision(1)
        << (total_ms > 0 ? 100 * pass.total_ms / total_ms : 0.0) << "%\n";
  }
  const double particle_steps = double(sim.particle_count()) * double(steps);
  out << std::left << std::setw(18) << "total" << std::right << std::setprecision(3)
      << std::setw(12) << (steps ? total_ms / double(steps) : 0.0) << "\n\n"
      << steps << " steps of " << sim.particle_count() << " particles in " << std::setprecision(2)
      << wall_s << " s "
      << (sim.device().is_cuda() ? "on " + sim.DeviceDescription()
                                 : "with " + std::to_string(threads) + " threads")
      << ": " << std::setprecision(2) << (wall_s > 0 ? particle_steps / wall_s / 1e6 : 0.0)
      << " million particle-steps/s\n";
  out.unsetf(std::ios::floatfield);
}

}  // namespace

void RunOffline(const RunOptions& options, std::ostream& out, std::ostream& progress) {
  if (options.vtk_to && *options.vtk_to < options.vtk_from) {
    throw ConfigError("--vtk-to", "must be at least --vtk-from (" + Number(options.vtk_from) +
                                      " s), got " + Number(*options.vtk_to) + " s");
  }
  Scene scene = LoadScene(options.scene);
  for (const std::string& assignment : options.sets) SetParamFromString(scene.params, assignment);
  BlockParticleCounts(scene, scene.params);
  if (options.threads > 0) omp_set_num_threads(options.threads);
  const int threads = options.threads > 0 ? options.threads : omp_get_max_threads();

  Simulation sim(std::move(scene), options.device);
  const Scene& sc = sim.scene();
  const double end_time = options.end_time.value_or(sc.end_time);
  // A physical solver's steps are CFL-adaptive: each is capped so that it lands exactly on the
  // next probe row, VTK frame or the end (so rows are at exact multiples of the interval).
  const bool adaptive = sim.model().physical;
  const double frame_time =
      adaptive ? sim.model().FrameTime() : sim.model().dt * sim.params().iterations_per_frame;
  const double interval = sc.probe_interval.value_or(frame_time);

  const std::filesystem::path dir(options.out_dir);
  std::filesystem::create_directories(dir);
  ProbeWriter probes(dir / "probes.csv", sc);
  std::optional<VtkSeriesWriter> vtk;
  if (options.vtk_every > 0) vtk.emplace(dir, "frames");

  out << "scene " << sc.name << ": " << sim.particle_count() << " particles, solver " << sc.solver
      << (sim.device().is_cuda() ? " on " + sim.DeviceDescription() : "") << ", "
      << (adaptive ? "adaptive dt <= " + Number(sim.params().max_time_step)
                   : "dt " + Number(sim.model().dt))
      << " s, "
      << (options.steps ? std::to_string(*options.steps) + " steps"
                        : "until t = " + Number(end_time) + " s")
      << ", output in " << dir.string() << "\n";

  // Frames only within [vtk_from, vtk_to] (a fine run's few milliseconds of interest would
  // otherwise write hundreds of MB a frame for the whole run).
  const double vtk_interval = frame_time * std::max(options.vtk_every, 1);
  const double vtk_to = options.vtk_to.value_or(std::numeric_limits<double>::infinity());
  auto vtk_wanted = [&](double time) {
    const double slack = 1e-9 * vtk_interval;
    return time + slack >= options.vtk_from && time - slack <= vtk_to;
  };
  probes.Write(sim.time(), sim.step(), sim.EvaluateProbes(sc.probes));
  if (vtk && vtk_wanted(0.0)) vtk->WriteFrame(sim.state().particles, 0.0);
  double next_output = interval;
  // The first multiple of the interval at or after vtk_from; adaptive steps land on it.
  double next_vtk = vtk_interval * std::max(1.0, std::ceil(options.vtk_from / vtk_interval - 1e-9));
  const auto start = Clock::now();
  auto last_progress = start;
  // Per step: the cheap accessors only (on a GPU, state() copies every particle array back);
  // state() only for the steps that write probes or frames.
  auto done = [&] {
    if (options.steps) return sim.step() >= *options.steps;
    return adaptive ? sim.time() >= end_time : sim.time() + 0.5 * sim.model().dt >= end_time;
  };
  while (!done()) {
    if (adaptive) {
      double until = std::min(next_output, options.steps ? next_output : end_time);
      if (vtk && next_vtk <= vtk_to * (1 + 1e-9)) until = std::min(until, next_vtk);
      sim.Step(until);
    } else {
      sim.Step();
    }
    const double time = sim.time();
    const uint64_t step = sim.step();
    if (time + 1e-9 * interval >= next_output) {
      probes.Write(sim.time(), sim.step(), sim.EvaluateProbes(sc.probes));
      while (next_output <= time + 1e-9 * interval) next_output += interval;
    }
    if (adaptive) {
      if (vtk && time + 1e-9 * vtk_interval >= next_vtk) {
        if (vtk_wanted(time)) vtk->WriteFrame(sim.state().particles, time);
        while (next_vtk <= time + 1e-9 * vtk_interval) next_vtk += vtk_interval;
      }
    } else {
      const uint64_t ipf = uint64_t(sim.params().iterations_per_frame);
      if (vtk && step % ipf == 0 && (step / ipf) % uint64_t(options.vtk_every) == 0 &&
          vtk_wanted(time)) {
        vtk->WriteFrame(sim.state().particles, time);
      }
    }
    const auto now = Clock::now();
    if (options.progress && Seconds(now - last_progress) > 0.25) {
      last_progress = now;
      const double wall = Seconds(now - start);
      progress << "\r  t = " << std::fixed << std::setprecision(3) << time << " s"
               << (options.steps ? "" : " / " + Number(end_time) + " s") << "  step " << step
               << "  " << std::setprecision(2)
               << double(sim.particle_count()) * double(step) / wall / 1e6
               << " M particle-steps/s   " << std::flush;
      progress.unsetf(std::ios::floatfield);
    }
  }
  const double wall_s = Seconds(Clock::now() - start);
  if (options.progress) progress << "\r" << std::string(72, ' ') << "\r" << std::flush;
  PrintProfile(sim, wall_s, sim.step(), threads, out);
  out << "probes: " << (dir / "probes.csv").string();
  if (vtk)
    out << ", ParaView series: " << (dir / "frames.pvd").string() << " (" << vtk->frames()
        << " frames)";
  out << "\n";
  if (options.print_hash) {
    char hash[19];
    std::snprintf(hash, sizeof hash, "0x%016llx",
                  static_cast<unsigned long long>(StateHash(sim.state())));
    out << "state hash: " << hash << "\n";
  }
}

}  // namespace dysa
