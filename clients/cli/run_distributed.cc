#include "run_distributed.h"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <optional>
#include <ostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "dysa/core/device.h"
#include "dysa/core/probes.h"
#include "dysa/distributed/distributed_simulation.h"
#include "dysa/distributed/rank_device.h"
#include "probe_writer.h"
#include "vtk_writer.h"

namespace dysa {
namespace {

using Clock = std::chrono::steady_clock;
const char* const kAxes[] = {"x", "y", "z"};

std::string Number(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

std::string Hex(uint64_t v) {
  char text[19];
  std::snprintf(text, sizeof text, "0x%016llx", static_cast<unsigned long long>(v));
  return text;
}

}  // namespace

void RunDistributed(const RunOptions& options, const distributed::Communicator& comm,
                    std::ostream& out) {
  Scene scene = LoadScene(options.scene);
  for (const std::string& assignment : options.sets) SetParamFromString(scene.params, assignment);
  if (options.threads > 0) omp_set_num_threads(options.threads);
  const int threads = options.threads > 0 ? options.threads : omp_get_max_threads();
  const bool gpu = options.device.is_cuda();
  if (gpu) {
    // What GPU ranks run is the same on every rank; whether a rank can use its GPU may not be
    // (another host), so all learn it before the first collective of the run.
    distributed::DistributedSimulation::CheckSupported(scene, scene.params, options.device);
    distributed::CheckRankDevicesUsable(comm, options.device);
  }

  distributed::DistributedSimulation sim(std::move(scene), comm, options.device);
  // Each rank's GPU (DeviceOfRank: by local rank where --device cuda has no index).
  const std::vector<Device> gpu_of_rank =
      gpu ? distributed::DevicesOfRanks(comm, options.device) : std::vector<Device>{};
  distributed::BalanceSettings balance;
  balance.threshold = options.balance_threshold;
  // Test-only (mpi_balance_test): DYSA_TEST_SLOW_RANK=RANK:MICROSECONDS slows that rank by as
  // much per owned particle and step.
  if (const char* slow = std::getenv("DYSA_TEST_SLOW_RANK")) {
    if (std::sscanf(slow, "%d:%lf", &balance.slow_rank, &balance.slow_us_per_particle) != 2) {
      throw std::invalid_argument("DYSA_TEST_SLOW_RANK: expected RANK:MICROSECONDS");
    }
  }
  sim.set_balance(balance);
  const Model& model = sim.model();
  const Scene& sc = sim.scene();
  const uint64_t particles = sim.TotalParticles();
  const double end_time = options.end_time.value_or(sc.end_time);
  const bool root = comm.rank() == 0;
  // The same steps, caps and output times as RunOffline: each adaptive step lands on the next
  // probe row, VTK frame or the end.
  const bool adaptive = model.physical;
  const double frame_time =
      adaptive ? model.FrameTime() : model.dt * model.params.iterations_per_frame;
  const double interval = sc.probe_interval.value_or(frame_time);

  // Rank 0 writes; whether it can is known to all before the first collective write.
  const std::filesystem::path dir(options.out_dir);
  std::optional<ProbeWriter> probes;
  std::optional<VtkSeriesWriter> vtk;
  std::string failure;
  if (root) {
    try {
      std::filesystem::create_directories(dir);
      probes.emplace(dir / "probes.csv", sc);
      if (options.vtk_every > 0) vtk.emplace(dir, "frames");
    } catch (const std::exception& e) {
      failure = e.what();
    }
  }
  double failed = failure.empty() ? 0 : 1;
  comm.MaxInPlace({&failed, 1});
  if (failed > 0) throw CollectiveError(root ? failure : "rank 0 cannot write its output");

  // Collective: every rank gathers its particles to rank 0, which evaluates or writes them in
  // the storage order of one process.
  auto write_probes = [&] {
    State whole;
    whole.particles = sim.GatherParticles();
    whole.time = sim.time();
    whole.step = sim.step();
    if (root) probes->Write(sim.time(), sim.step(), EvaluateProbes(sc.probes, model, whole));
  };
  auto write_frame = [&] {
    const ParticleArrays all = sim.GatherParticles();
    if (root) vtk->WriteFrame(all, sim.time());
  };

  if (root) {
    out << "scene " << sc.name << ": " << particles << " particles, solver " << sc.solver << " on "
        << comm.size() << " ranks x " << threads << " threads, slabs along " << kAxes[sim.axis()]
        << " (" << sim.slabs().layers() << " cell layers), "
        << (options.steps ? std::to_string(*options.steps) + " steps"
                          : "until t = " + Number(end_time) + " s")
        << ", output in " << dir.string() << "\n";
    if (gpu) {
      out << "devices per rank:";
      for (const Device& device : gpu_of_rank) out << " " << device.ToString();
      out << "\n";
    }
  }
  write_probes();
  if (options.vtk_every > 0) write_frame();
  double next_output = interval;
  const double vtk_interval = frame_time * std::max(options.vtk_every, 1);
  double next_vtk = vtk_interval;
  const auto start = Clock::now();
  // Particles this rank owned after each step, summed: the share it held while the fluid moved
  // (the slabs chase a moving body, so the count at the end alone says little).
  int64_t held = 0;
  int64_t samples = 0;
  auto done = [&] {
    if (options.steps) return sim.step() >= *options.steps;
    return adaptive ? sim.time() >= end_time : sim.time() + 0.5 * model.dt >= end_time;
  };
  while (!done() && sim.alarm().empty()) {
    if (adaptive) {
      double until = std::min(next_output, options.steps ? next_output : end_time);
      if (options.vtk_every > 0) until = std::min(until, next_vtk);
      sim.Step(until);
    } else {
      sim.Step();
    }
    held += int64_t(sim.particles().size());
    ++samples;
    const double time = sim.time();
    const uint64_t step = sim.step();
    if (time + 1e-9 * interval >= next_output) {
      write_probes();
      while (next_output <= time + 1e-9 * interval) next_output += interval;
    }
    if (options.vtk_every > 0) {
      if (adaptive) {
        if (time + 1e-9 * vtk_interval >= next_vtk) {
          write_frame();
          while (next_vtk <= time + 1e-9 * vtk_interval) next_vtk += vtk_interval;
        }
      } else {
        const uint64_t ipf = uint64_t(model.params.iterations_per_frame);
        if (step % ipf == 0 && (step / ipf) % uint64_t(options.vtk_every) == 0) write_frame();
      }
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
  std::vector<int64_t> held_per_rank(size_t(comm.size()), 0);
  held_per_rank[size_t(comm.rank())] = held;
  comm.SumInPlace(held_per_rank);
  const distributed::ExchangeTotals& t = sim.totals();
  // The exchange without the wait for the slowest rank (its own packing, transfer and sort),
  // and that wait, each at the rank where it is longest.
  std::vector<double> exchange_parts = {sim.profile().front().total_ms - t.wait_ms, t.wait_ms};
  comm.MaxInPlace(exchange_parts);
  std::vector<int64_t> moved = {int64_t(t.migrated), int64_t(t.ghosts), int64_t(t.bytes_sent)};
  comm.SumInPlace(moved);
  const distributed::BalanceReport& balanced = sim.balance();
  const uint64_t hash = options.print_hash ? sim.GlobalStateHash() : 0;
  if (!root) return;

  const uint64_t steps = sim.step();
  double total_ms = 0;
  for (double ms : pass_ms) total_ms += ms;
  auto per_step = [&](double ms) { return steps ? ms / double(steps) : 0.0; };
  auto share = [&](double ms) { return total_ms > 0 ? 100 * ms / total_ms : 0.0; };
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
  out << "\nmean particles per rank over the steps:" << std::setprecision(0) << std::fixed;
  for (int64_t n : held_per_rank) out << " " << (samples > 0 ? double(n) / double(samples) : 0.0);
  out.unsetf(std::ios::floatfield);
  out << std::setprecision(3);
  out << "\nmigrated: " << moved[0]
      << " particles; ghosts per step: " << (steps ? double(moved[1]) / double(steps) : 0.0)
      << "; bytes sent per step: " << (steps ? double(moved[2]) / double(steps) : 0.0) << "\n"
      << "exchange without waiting: " << per_step(exchange_parts[0]) << " ms per step ("
      << std::setprecision(1) << std::fixed << share(exchange_parts[0])
      << "% of the step); waiting for the slowest rank first: " << std::setprecision(3)
      << per_step(exchange_parts[1]) << " ms per step\n";
  out.unsetf(std::ios::floatfield);
  out << std::setprecision(3) << "re-balanced: " << t.recuts << " of " << steps
      << " steps moved a slab cut\n"
      << (balanced.by_work ? "work max/mean (GPU ranks balance the work): "
                           : "step time max/mean: ")
      << std::fixed << std::setprecision(2) << balanced.first_ratio << " over the first "
      << balance.window << " steps, " << balanced.last_ratio << " over the last " << balance.window
      << ", " << (balanced.windows ? balanced.ratio_sum / double(balanced.windows) : 1.0)
      << " in the mean of the " << balanced.windows << " windows (threshold " << balance.threshold
      << ")\n";
  out.unsetf(std::ios::floatfield);
  if (!sim.alarm().empty()) out << "stopped: " << sim.alarm() << "\n";
  out << "probes: " << (dir / "probes.csv").string();
  if (vtk) {
    out << ", ParaView series: " << (dir / "frames.pvd").string() << " (" << vtk->frames()
        << " frames)";
  }
  out << "\n";
  if (options.print_hash) out << "state hash: " << Hex(hash) << "\n";
}

}  // namespace dysa
