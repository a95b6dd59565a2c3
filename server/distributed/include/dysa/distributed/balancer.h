// Re-balancing the slabs by measured step time (docs/distributed.md, "Re-balancing").
//
// Each process measures its own step's compute time (the solver's passes, without the waits in
// collectives) and the work of its slab: per layer, the fluid particles it owns there plus the
// boundary particles of the layer. Every `window` steps the processes combine the layers' work,
// their times and their work in one sum (integers, so every process computes the same cuts).
// When the window's max/mean of the processes' step times exceeds `threshold`, the cuts move to
// balance the estimated cost, each process's speed (its time per unit of work) times the work of
// its slab, provided the new cuts promise a max/mean lower by `margin` (hysteresis: noise does
// not shuffle the cuts). A re-cut is judged by the next window: where its max/mean is not lower,
// the step times do not follow the work (fixed costs per step, processes sharing one GPU), the
// cut is undone and re-cutting pauses for 1, 2, 4, ... windows. The cuts change no bit of the
// result (the order keys do not depend on where a particle lives).
//
// GPU ranks balance the work alone (BalanceSettings::by_work): a GPU's step time is mostly fixed
// costs per step and, where ranks share a GPU, the other ranks' kernels, so per-rank speeds
// measured from it are noise. On an H100 shared by 2-3 ranks the time-based balancer, undo and
// all, ended the test dam break with every particle on one rank (mpi_gpu_ranks_test). By work,
// the cuts are also the same on every run: they depend on no clock.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "dysa/distributed/communicator.h"
#include "dysa/distributed/slabs.h"

namespace dysa::distributed {

struct BalanceSettings {
  // Re-cut when the window's max/mean of the processes' step times exceeds this.
  double threshold = 1.1;
  // Steps whose times are summed before max/mean is judged; a re-cut starts a new window.
  int window = 10;
  // Hysteresis: the new cuts must promise a max/mean (from the per-layer costs) at least this
  // much (relative) below the measured one.
  double margin = 0.05;
  // Test-only: process `slow_rank` spends slow_us_per_particle microseconds per owned particle
  // each step asleep, counted as compute, to make a deliberately imbalanced run.
  int slow_rank = -1;
  double slow_us_per_particle = 0;
  // Every process taken as equally fast: max/mean and the cuts from the work alone, no clock
  // (DistributedSimulation sets it on GPU ranks).
  bool by_work = false;
};

// What the balancer saw: max/mean of the step times (of the work, by_work) over the first window
// (before any re-cut), over the latest window and summed over the windows, and how many re-cuts it
// made.
struct BalanceReport {
  double first_ratio = 0;
  double last_ratio = 0;
  double ratio_sum = 0;  // / windows: the mean of the windows' max/mean
  uint64_t windows = 0;
  uint64_t recuts = 0;
  uint64_t undone = 0;   // re-cuts undone: the next window's max/mean was not lower
  bool by_work = false;  // the ratios are of the work (BalanceSettings::by_work)
};

// Cuts (speed.size() + 1 entries, from 0 to work.size()) that minimise the largest cost of a
// slab, process p's cost being speed[p] times the work of its layers, each process keeping at
// least one layer. Deterministic: the same inputs give the same cuts on every process.
std::vector<int> CutsForCosts(std::span<const int64_t> work, std::span<const double> speed);
// max/mean over the processes of those costs under `cuts` (1 for equal costs).
double CostRatio(std::span<const int64_t> work, std::span<const double> speed,
                 std::span<const int> cuts);

class Balancer {
 public:
  explicit Balancer(BalanceSettings settings = {}) : settings_(settings) {}
  const BalanceSettings& settings() const { return settings_; }
  void set_settings(const BalanceSettings& settings) { settings_ = settings; }
  const BalanceReport& report() const { return report_; }

  // After a step: this process's compute time `ms` and the work of its slab's layers
  // (`weights`: one per layer, those outside the slab ignored).
  void Record(double ms, const Slabs& slabs, int rank, std::span<const int64_t> weights);
  // Collective, after every step (a sum over the processes at the end of each window only):
  // true when it moved the cuts.
  bool Rebalance(const Communicator& comm, Slabs& slabs);
  // Forgets the window, a re-cut's pending check and any pause (new slabs: a restore, new
  // parameters).
  void Restart();

 private:
  // The longest pause after undone re-cuts, in windows.
  static constexpr int kMostPausedWindows = 64;
  // The most a process's estimated time per unit of work may exceed the fastest one's: a
  // process keeps at least a quarter of the work per process of the fastest (mpi_balance_test's
  // slowed rank, about twice as slow, is within it).
  static constexpr double kMostSlower = 4;
  void ClearWindow();

  BalanceSettings settings_;
  BalanceReport report_;
  int steps_ = 0;
  double time_ms_ = 0;         // this process's compute time in the window
  int64_t own_work_ = 0;       // ... and its work
  std::vector<int64_t> work_;  // per layer, of its slab's layers
  std::vector<double> speed_;  // each process's estimated time per unit of work
  // The latest re-cut, checked at the next window's end: the cuts and max/mean before it.
  bool checking_ = false;
  double ratio_before_ = 0;
  std::vector<int> cuts_before_;
  int pause_windows_ = 0;  // windows left without re-cutting
  int next_pause_ = 1;     // the next pause, doubled by each undone re-cut
};

}  // namespace dysa::distributed
