#include "dysa/distributed/balancer.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

namespace dysa::distributed {

namespace {

// Whether slabs of cost at most `limit` each (process p's cost: speed[p] times its layers'
// work) cover every layer, each process keeping at least one; fills `cuts` when they do.
bool CoverWithin(std::span<const int64_t> work, std::span<const double> speed, double limit,
                 std::vector<int>& cuts) {
  const int layers = int(work.size());
  const int processes = int(speed.size());
  int layer = 0;
  for (int p = 0; p < processes; ++p) {
    cuts[p] = layer;
    const int last = layers - (processes - 1 - p);  // leave a layer to each later process
    double cost = speed[p] * double(work[layer++]);
    if (cost > limit) return false;
    while (layer < last && (p + 1 == processes || cost + speed[p] * double(work[layer]) <= limit)) {
      cost += speed[p] * double(work[layer++]);
    }
    if (cost > limit) return false;
  }
  cuts[processes] = layers;
  return layer == layers;
}

}  // namespace

std::vector<int> CutsForCosts(std::span<const int64_t> work, std::span<const double> speed) {
  const int processes = int(speed.size());
  std::vector<int> cuts(size_t(processes) + 1, 0);
  double hi = 0;
  for (size_t l = 0; l < work.size(); ++l) hi += double(work[l]);
  double fastest = 0;
  for (double s : speed) fastest = std::max(fastest, s);
  hi *= fastest;
  if (!(hi > 0)) {
    // No work (or no speed) to balance: equal layer counts.
    for (int p = 0; p <= processes; ++p) cuts[p] = int(int64_t(work.size()) * p / processes);
    return cuts;
  }
  // The least limit whose greedy cover succeeds, by bisection (the same on every process: the
  // same inputs, the same operations); then the cover at that limit.
  double lo = 0;
  for (int k = 0; k < 100 && hi - lo > 1e-9 * hi; ++k) {
    const double mid = 0.5 * (lo + hi);
    if (CoverWithin(work, speed, mid, cuts)) {
      hi = mid;
    } else {
      lo = mid;
    }
  }
  if (!CoverWithin(work, speed, hi, cuts)) {
    // Only when the bisection hit its cap: equal layer counts.
    for (int p = 0; p <= processes; ++p) cuts[p] = int(int64_t(work.size()) * p / processes);
  }
  return cuts;
}

double CostRatio(std::span<const int64_t> work, std::span<const double> speed,
                 std::span<const int> cuts) {
  const int processes = int(speed.size());
  double total = 0;
  double most = 0;
  for (int p = 0; p < processes; ++p) {
    double slab = 0;
    for (int l = cuts[p]; l < cuts[p + 1]; ++l) slab += double(work[l]);
    slab *= speed[p];
    total += slab;
    most = std::max(most, slab);
  }
  return total > 0 ? most * processes / total : 1.0;
}

void Balancer::Record(double ms, const Slabs& slabs, int rank, std::span<const int64_t> weights) {
  work_.resize(size_t(slabs.layers()), 0);
  time_ms_ += ms;
  for (int l = slabs.begin(rank); l < slabs.begin(rank + 1); ++l) {
    work_[l] += weights[l];
    own_work_ += weights[l];
  }
}

bool Balancer::Rebalance(const Communicator& comm, Slabs& slabs) {
  if (++steps_ < std::max(settings_.window, 1)) return false;
  const int processes = comm.size();
  const int layers = slabs.layers();
  work_.resize(size_t(layers), 0);
  // Summed as integers (the times in nanoseconds): every process gets the same values and so
  // computes the same cuts. The layers' work, then each process's time, then its work.
  std::vector<int64_t> sums(size_t(layers + 2 * processes), 0);
  std::copy(work_.begin(), work_.end(), sums.begin());
  sums[size_t(layers + comm.rank())] = settings_.by_work ? own_work_ : std::llround(time_ms_ * 1e6);
  sums[size_t(layers + processes + comm.rank())] = own_work_;
  comm.SumInPlace(sums);
  ClearWindow();
  const std::span<const int64_t> work(sums.data(), size_t(layers));
  const std::span<const int64_t> time(sums.data() + layers, size_t(processes));
  const std::span<const int64_t> done(sums.data() + layers + processes, size_t(processes));
  int64_t most = 0;
  int64_t total = 0;
  int64_t time_worked = 0;
  int64_t work_timed = 0;
  for (int p = 0; p < processes; ++p) {
    most = std::max(most, time[p]);
    total += time[p];
    if (done[p] > 0) {
      time_worked += time[p];
      work_timed += done[p];
    }
  }
  const double ratio = total > 0 ? double(most) * processes / double(total) : 1.0;
  report_.by_work = settings_.by_work;
  if (report_.windows++ == 0) report_.first_ratio = ratio;
  report_.last_ratio = ratio;
  report_.ratio_sum += ratio;
  // The previous window's re-cut, judged: where the step times do not follow the work (a fixed
  // cost per step, processes sharing one GPU), moving work does not lower max/mean and the speed
  // estimates drift (a process with less work looks slower per unit of work and is given still
  // less). Such a re-cut is undone and re-cutting pauses, for twice as many windows each time.
  if (checking_) {
    checking_ = false;
    if (ratio >= ratio_before_) {
      slabs.SetCuts(cuts_before_);
      ++report_.undone;
      pause_windows_ = next_pause_;
      next_pause_ = std::min(2 * next_pause_, kMostPausedWindows);
      return true;
    }
    next_pause_ = 1;
  }
  if (pause_windows_ > 0) {
    --pause_windows_;
    return false;
  }
  if (ratio <= settings_.threshold || work_timed == 0) return false;
  // Each process's speed: its time per unit of work, re-measured where it did at least half the
  // mean work (a process with little or no work times mostly its fixed costs, and would seem
  // fast); otherwise its previous estimate, or the mean speed before it has one.
  const double mean_speed = double(time_worked) / double(work_timed);
  speed_.resize(size_t(processes), 0.0);
  if (settings_.by_work) std::fill(speed_.begin(), speed_.end(), 1.0);
  for (int p = 0; p < processes && !settings_.by_work; ++p) {
    if (2 * done[p] * processes >= work_timed) {
      speed_[p] = double(time[p]) / double(done[p]);
    } else if (!(speed_[p] > 0)) {
      speed_[p] = mean_speed;
    }
  }
  // At most kMostSlower times the fastest process's time per unit of work: the processes of one
  // job run on like cores, and a time further off is the machine's load (4 ranks on 2 busy
  // cores), not the process. Unbounded, such noise once gave one of 2 ranks all of the seed's
  // 3,072 particles and the other only empty layers (mpi_ranks_test beside a parallel build).
  if (!settings_.by_work) {
    const double fastest = *std::min_element(speed_.begin(), speed_.end());
    for (double& s : speed_) s = std::min(s, kMostSlower * fastest);
  }
  const std::span<const double> speed = speed_;
  const std::vector<int> cuts = CutsForCosts(work, speed);
  if (std::equal(cuts.begin(), cuts.end(), slabs.cuts().begin())) return false;
  if (CostRatio(work, speed, cuts) * (1 + settings_.margin) >
      CostRatio(work, speed, slabs.cuts())) {
    return false;
  }
  // Never cuts a process down to empty layers while there is work for each: an idle process
  // only waits, and its speed can no longer be measured (the seed on 2 loaded CPU ranks ended
  // `0 3072` with the speed cap alone).
  int64_t total_work = 0;
  for (int64_t w : work) total_work += w;
  for (int p = 0; p < processes && total_work >= processes; ++p) {
    int64_t slab = 0;
    for (int l = cuts[size_t(p)]; l < cuts[size_t(p) + 1]; ++l) slab += work[size_t(l)];
    if (slab == 0) return false;
  }
  cuts_before_.assign(slabs.cuts().begin(), slabs.cuts().end());
  ratio_before_ = ratio;
  checking_ = true;
  slabs.SetCuts(cuts);
  ++report_.recuts;
  return true;
}

void Balancer::Restart() {
  ClearWindow();
  checking_ = false;
  pause_windows_ = 0;
  next_pause_ = 1;
}

void Balancer::ClearWindow() {
  steps_ = 0;
  time_ms_ = 0;
  own_work_ = 0;
  std::fill(work_.begin(), work_.end(), 0);
}

}  // namespace dysa::distributed
