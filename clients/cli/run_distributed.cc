#include "run_distributed.h"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iomanip>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

#include "dysa/distributed/distributed_simulation.h"

namespace dysa {
namespace {

using Clock = std::chrono::steady_clock;
const char* const kAxes[] = {"x", "y", "z"};

std::string Hex(uint64_t v) {
  char text[19];
  std::snprintf(text, sizeof text, "0x%016llx", static_cast<unsigned long long>(v));
  return text;
}

}  // namespace

void RunDistributed(const RunOptions& options, const distributed::Communicator& comm,
                    std::ostream& out) {
  if (options.vtk_every > 0) {
    throw std::invalid_argument(
        "--vtk-every: frames are not written across ranks yet; run without mpirun for them");
  }
  if (options.device.is_cuda()) {
    throw std::invalid_argument("--device: only cpu runs across ranks yet");
  }
  Scene scene = LoadScene(options.scene);
  for (const std::string& assignment : options.sets) SetParamFromString(scene.params, assignment);
  if (options.threads > 0) omp_set_num_threads(options.threads);
  const int threads = options.threads > 0 ? options.threads : omp_get_max_threads();

  distributed::DistributedSimulation sim(std::move(scene), comm);
  const Model& model = sim.model();
  const uint64_t particles = sim.TotalParticles();
  const Scene& sc = sim.scene();
  const double end_time = options.end_time.value_or(sc.end_time);
  const bool root = comm.rank() == 0;
  // RunOffline caps each adaptive step at the next probe row: the same caps give the same steps.
  const bool adaptive = model.physical;
  const double interval = sc.probe_interval.value_or(
      adaptive ? model.FrameTime() : model.dt * model.params.iterations_per_frame);
  if (root) {
    out << "scene " << sc.name << ": " << particles << " particles, solver " << sc.solver << " on "
        << comm.size() << " ranks x " << threads << " threads, slabs along " << kAxes[sim.axis()]
        << " (" << sim.slabs().layers() << " cell layers), "
        << (options.steps ? std::to_string(*options.steps) + " steps"
                          : "until t = " + std::to_string(end_time) + " s")
        << "; no probes or frames across ranks\n";
  }
  double next_output = interval;
  const auto start = Clock::now();
  auto done = [&] {
    if (options.steps) return sim.step() >= *options.steps;
    return adaptive ? sim.time() >= end_time : sim.time() + 0.5 * model.dt >= end_time;
  };
  while (!done() && sim.alarm().empty()) {
    if (!adaptive) {
      sim.Step();
      continue;
    }
    sim.Step(std::min(next_output, options.steps ? next_output : end_time));
    const double time = sim.time();
    if (time + 1e-9 * interval >= next_output) {
      while (next_output <= time + 1e-9 * interval) next_output += interval;
    }
  }
  const double wall_s = std::chrono::duration<double>(Clock::now() - start).count();

  // The slowest rank's time per pass: the step waits for it.
  std::vector<double> pass_ms;
  for (const PassProfile& pass : sim.profile()) pass_ms.push_back(pass.total_ms);
  comm.MaxInPlace(pass_ms);
  std::vector<int64_t> per_rank(size_t(comm.size()), 0);
  per_rank[size_t(comm.rank())] = int64_t(sim.particles().size());
  comm.SumInPlace(per_rank);
  const distributed::ExchangeTotals& t = sim.totals();
  std::vector<int64_t> moved = {int64_t(t.migrated), int64_t(t.ghosts), int64_t(t.bytes_sent)};
  comm.SumInPlace(moved);
  const uint64_t hash = options.print_hash ? sim.GlobalStateHash() : 0;
  if (!root) return;

  const uint64_t steps = sim.step();
  double total_ms = 0;
  for (double ms : pass_ms) total_ms += ms;
  out << "\n"
      << std::left << std::setw(18) << "pass" << std::right << std::setw(12) << "ms/step"
      << std::setw(10) << "share\n";
  for (size_t k = 0; k < pass_ms.size(); ++k) {
    out << std::left << std::setw(18) << sim.profile()[k].name << std::right << std::fixed
        << std::setprecision(3) << std::setw(12) << (steps ? pass_ms[k] / double(steps) : 0.0)
        << std::setw(9) << std::setprecision(1)
        << (total_ms > 0 ? 100 * pass_ms[k] / total_ms : 0.0) << "%\n";
  }
  out.unsetf(std::ios::floatfield);
  out << "\n"
      << steps << " steps of " << particles << " particles in " << std::setprecision(3) << wall_s
      << " s on " << comm.size()
      << " ranks: " << (wall_s > 0 ? double(particles) * double(steps) / wall_s / 1e6 : 0.0)
      << " million particle-steps/s\n";
  out << "particles per rank:";
  for (int64_t n : per_rank) out << " " << n;
  out << "\nmigrated: " << moved[0]
      << " particles; ghosts per step: " << (steps ? double(moved[1]) / double(steps) : 0.0)
      << "; bytes sent per step: " << (steps ? double(moved[2]) / double(steps) : 0.0) << "\n";
  if (!sim.alarm().empty()) out << "stopped: " << sim.alarm() << "\n";
  if (options.print_hash) out << "state hash: " << Hex(hash) << "\n";
}

}  // namespace dysa
