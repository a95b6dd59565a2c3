// `dysa run`: simulate a scene offline, without a server.
#pragma once

#include <cstdint>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

#include "dysa/core/device.h"

namespace dysa {

struct RunOptions {
  std::string scene;               // built-in name or JSON file
  std::vector<std::string> sets;   // NAME=VALUE parameter overrides
  std::optional<double> end_time;  // s; default: the scene's end_time
  std::optional<uint64_t> steps;   // instead of end_time
  int threads = 0;                 // 0: OpenMP's default
  Device device;                   // where the steps run (--device): the CPU or a CUDA GPU
  std::string out_dir = "out";
  int vtk_every = 0;             // write a VTK frame every K frames; 0: none
  double vtk_from = 0;           // s: no VTK frame before this simulated time
  std::optional<double> vtk_to;  // s: none after it (default: until the end)
  bool progress = false;         // a live progress line on stderr
  bool print_hash = false;       // print the final StateHash (--hash)
  // Under mpirun: re-cut the slabs when max/mean of the ranks' step times exceeds this
  // (--balance-threshold; distributed::BalanceSettings).
  double balance_threshold = 1.1;
  // Under mpirun: a collective that waits longer than this for the other ranks (one hangs)
  // ends the job (--rank-timeout, s; distributed::MpiCommunicator).
  double rank_timeout = 30;
};

// Runs the scene and writes OUT/probes.csv (and VTK frames); prints the per-pass timing table
// and throughput to `out`. Throws ConfigError for bad scenes or parameters,
// ConfigError("device", ...) when options.device cannot run (naming what is missing) or has no
// backend for the scene's solver, and std::runtime_error for I/O failures.
void RunOffline(const RunOptions& options, std::ostream& out, std::ostream& progress);

}  // namespace dysa
