// DistributedSimulation's step on a GPU (distributed_simulation.h): the host's exchange, then
// the solver's CUDA pipeline over this process's owned particles and ghosts.
//
// Why the bits are those of one process. The exchange leaves the particles in key order (the
// order one process would hold them in, cell by cell); the device's neighbour sort is a stable
// radix sort by the same cells (device_grid.cuh), so it puts them in the order the CPU's stable
// counting sort does, and every cell an owned particle reads is complete (the ghost layers, as
// on the CPU). The ghosts run every pass on the device (the CPU path skips those no owned
// particle reads of them): their results are wrong near the halo's far edge, but nothing owned
// reads them and they are dropped. What steers the step are the CFL maxima: the device leaves
// out the particles sorted into layers this process does not own (ProcessShare::owned_layers,
// the CPU's ghost flags) and the backend combines them, with the fullest cell, over the
// processes (ProcessShare::max_over_processes) before it chooses dt.
//
// The seed sorts by its predicted positions: a particle is owned where its predicted cell lies
// (the ghosts' slack, 2 layers, checked by the count of owners), and its step, of a fixed dt,
// has no maxima.
//
// The predictor-corrector sorts twice; the ghosts reach 5 layers as on the CPU (those within 3
// compute their rates there, all of them here), the maxima are taken after the first sort (by
// its cells), and a particle's owner and order key come from the second (the last the device
// made). The CPU's check that no particle moved more than one layer between the sorts (the
// ghosts' slack) is made here after the step, from the first sort's cells by id
// (StepBackend::DownloadFirstSortCells).
//
// dfsph refreshes its ghosts' velocities from their owners after every update of them inside
// the step (each iteration of both pressure solves, their warm starts and predict_velocity),
// and its solves stop on a mean error over the owned particles summed over the processes. On the
// device both go through the backend: after its neighbour sort it hands the host each particle's
// id and cell, DeviceGhosts (below) plans the refresh as the CPU path's AfterSort does and
// returns the ghost flags with the pattern, and each refresh reads back only the owned particles
// others read, exchanges them through the same GhostRefresh and writes the ghosts; the sums
// (fixed-point integers, exact) and maxima go through ProcessShare's hooks as on the CPU. So
// every operand of every owned particle is the one a single process has, as on CPU ranks, and
// every process takes the same iterations.
#include <algorithm>
#include <chrono>
#include <climits>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "device_ghosts.h"
#include "dysa/distributed/distributed_simulation.h"

namespace dysa::distributed {
namespace {

using Clock = std::chrono::steady_clock;

double MsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// The layer along `axis` of cell index `cell` (NeighborGrid::CellIndex) in a grid of `dims`.
int LayerOf(uint32_t cell, const Eigen::Vector3i& dims, int axis) {
  const uint32_t nx = uint32_t(dims.x()), ny = uint32_t(dims.y());
  if (axis == 0) return int(cell % nx);
  if (axis == 1) return int((cell / nx) % ny);
  return int(cell / (nx * ny));
}

}  // namespace

bool DistributedSimulation::RunDeviceStep(double start_time, bool& finite) {
  auto start = Clock::now();
  WaitAndExchange();
  Record(0, MsSince(start));
  collective_ms_ = 0;
  const auto compute_start = Clock::now();
  ProcessShare& share = state_.share;
  const int me = comm_.rank();
  share.layer_axis = axis_;
  share.owned_layers.assign(size_t(slabs_->layers()), 0);
  for (int l = 0; l < slabs_->layers(); ++l)
    share.owned_layers[size_t(l)] = slabs_->OwnerOf(l) == me;
  // The device sorts; the flags follow from its cells below (dfsph's: from its plan).
  share.ghost.clear();
  share.device_ghosts = device_ghosts_.get();

  start = Clock::now();
  backend_->Upload(state_.particles, solver_->SaveArrays());
  Record(1, MsSince(start));
  const StepBackend::StepReport report = backend_->Step(model_, state_);
  const size_t download_pass = profile_.size() - 2;
  for (size_t k = 0; k < report.pass_ms.size() && k + 2 < download_pass; ++k) {
    Record(k + 2, report.pass_ms[k]);
  }

  // Back to the host: the particles in the device's sorted order (moved, unless the step
  // stopped before it integrated), the carried density, and the cells of the sort.
  start = Clock::now();
  backend_->Download(state_.particles);
  std::vector<SolverArray> arrays;
  if (!backend_->DownloadSolverArrays(arrays) || !backend_->DownloadSortedCells(sorted_cells_)) {
    throw std::logic_error("the device backend does not read back what the ranks need");
  }
  Record(download_pass, MsSince(start));
  const size_t n = state_.particles.size();
  if (sorted_cells_.size() != n) throw std::logic_error("the device's sort lost particles");

  // As AfterSort: a particle is owned where its sorted cell lies, a ghost elsewhere, and every
  // particle has exactly one owner.
  start = Clock::now();
  const Eigen::Vector3i dims = layout_.dims();
  share.ghost.assign(n, 0);
  int64_t owned = 0;
  for (size_t k = 0; k < n; ++k) {
    const int layer = LayerOf(sorted_cells_[k], dims, axis_);
    share.ghost[k] = uint8_t(std::min(255, slabs_->Distance(layer, me)));
    owned += share.ghost[k] ? 0 : 1;
  }
  const bool predictor = model_.params.time_integration == 1;
  double moved = predictor && !report.stopped ? double(DeviceHalfStepMove()) : 0;
  // The fullest cell over the processes (the seed's step completes past the limit; wcsph's stops
  // and its backend combined the count already) and the half step's move.
  double maxima[2] = {double(report.max_cell_count), moved};
  const auto wait = Clock::now();
  comm_.SumInPlace({&owned, 1});
  comm_.MaxInPlace(maxima);
  collective_ms_ += MsSince(wait);
  // The ghosts dropped, the order keys of the owned particles from the sort's cells.
  const std::vector<uint64_t> keys = OrderKeys(sorted_cells_);
  std::vector<uint8_t> keep(n);
  keys_.clear();
  for (size_t k = 0; k < n; ++k) {
    keep[k] = share.ghost[k] == 0;
    if (keep[k]) keys_.push_back(keys[k]);
  }
  KeepParticles(keep, state_.particles, arrays);
  solver_->RestoreArrays(arrays, state_.particles.size());
  share.ghost.clear();
  Record(profile_.size() - 1, MsSince(start));
  // The same on every process (maxima and a sum over them). Raised after the step where it
  // completed (the CPU raises them before it integrates): the step is not counted.
  if (report.stopped || maxima[0] > NeighborGrid::kMaxParticlesPerCell) {
    alarm_ = CrowdedAlarm(uint64_t(maxima[0]), start_time);
    return false;
  }
  if (maxima[1] > model_.grid_cells_per_support) {  // the ghosts' slack: one support
    alarm_ = MovedAlarm(int(maxima[1]), start_time);
    return false;
  }
  if (uint64_t(owned) != total_) {
    alarm_ = OwnerAlarm(owned, start_time);
    return false;
  }
  FinishStep(MsSince(compute_start), finite);
  return true;
}

DeviceGhostExchange::Plan DistributedSimulation::DeviceGhosts::PlanAfterSort(
    std::span<const uint32_t> id, std::span<const uint32_t> cell) {
  if (cell.size() != id.size()) throw std::logic_error("the device's sort lost particles");
  const size_t n = id.size();
  const Eigen::Vector3i dims = sim_.layout_.dims();
  const int me = sim_.comm_.rank();
  Plan plan;
  plan.ghost.resize(n);
  layer_.resize(n);
  for (size_t k = 0; k < n; ++k) {
    layer_[k] = LayerOf(cell[k], dims, sim_.axis_);
    plan.ghost[k] = uint8_t(std::min(255, sim_.slabs_->Distance(layer_[k], me)));
  }
  const auto start = Clock::now();
  sim_.ghost_refresh_.Plan(sim_.comm_, *sim_.slabs_, layer_, plan.ghost, id);
  sim_.collective_ms_ += MsSince(start);
  plan.sent = sim_.ghost_refresh_.Sent();
  plan.received = sim_.ghost_refresh_.Received();
  return plan;
}

void DistributedSimulation::DeviceGhosts::Exchange(std::span<const Vec3> sent,
                                                   std::span<Vec3> received) {
  const auto start = Clock::now();
  sim_.totals_.bytes_sent += sim_.ghost_refresh_.Exchange(sim_.comm_, sent, received);
  sim_.collective_ms_ += MsSince(start);
}

int DistributedSimulation::DeviceHalfStepMove() const {
  std::vector<uint32_t> ids, cells;
  if (!backend_->DownloadFirstSortCells(ids, cells) || ids.size() != cells.size()) {
    throw std::logic_error("the device backend kept no first sort of the predictor-corrector");
  }
  // Each particle's layer at the first sort, by id; then against its layer at the second.
  const Eigen::Vector3i dims = layout_.dims();
  std::vector<std::pair<uint32_t, int>> first(ids.size());
  for (size_t k = 0; k < ids.size(); ++k) first[k] = {ids[k], LayerOf(cells[k], dims, axis_)};
  std::sort(first.begin(), first.end());
  const ParticleArrays& p = state_.particles;
  if (first.size() != p.size() || sorted_cells_.size() != p.size()) {
    throw std::logic_error("the device's two sorts hold different particles");
  }
  const int layers = slabs_->layers();
  int moved = 0;
  for (size_t k = 0; k < p.size(); ++k) {
    const auto at = std::lower_bound(first.begin(), first.end(), std::pair{p.id[k], INT_MIN});
    if (at == first.end() || at->first != p.id[k]) {
      throw std::logic_error("a particle of the device's second sort is not in its first");
    }
    int d = std::abs(LayerOf(sorted_cells_[k], dims, axis_) - at->second);
    if (model_.periodic[axis_]) d = std::min(d, layers - d);
    moved = std::max(moved, d);
  }
  return moved;
}

}  // namespace dysa::distributed
