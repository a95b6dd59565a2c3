#include "dysa/distributed/distributed_simulation.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <thread>
#include <utility>

#include "device_ghosts.h"

namespace dysa::distributed {
namespace {

// Ghost layers each side of a slab, by solver. wcsph: an owned particle reads, within one cell,
// the fluid's positions, velocities and carried densities (exchanged) and what the pressure pass
// derives from them per particle; and the boundary particles' extrapolated pressure and wall
// velocity, which each sums over the fluid within one cell of that boundary particle: two cells
// from the owned one. seed: the pressure force reads the neighbours' densities (two cells) and
// the viscosity their velocities after the pressure force (three); and it sorts by positions
// predicted 1/120 s ahead, which the velocity limiter (smoothing_radius / dt) keeps within 2
// cells at the thesis's dt, so that the exchange, by the positions at the step's start, sends 2
// layers more. With these depths every value an owned particle reads is computed here from exact
// inputs, as on one process; the values of the ghosts themselves may be wrong (their
// neighbourhoods are cut) but nothing owned reads them, and they are dropped after the step.
// wcsph's predictor-corrector: after its second sort (by the positions at t + dt/2) an owned
// particle reads, as above, what lies within two cells of it at t + dt/2: predicted states,
// which need the first evaluation's rates, exact where their own reads (two cells more) are.
// With the half step's move of at most one layer (checked) that is 1 + 2 + 2 = 5 layers, and the
// ghosts within kPredictorReach layers compute their rates too.
// dfsph: an owned particle reads its neighbours' density and factor alpha (exact on ghosts up to
// depth - 1 layers: each sums over its own neighbours' positions), and the boundary particles'
// hydrostatic pressure and extrapolated kappa, which each sums over the fluid within a cell of it
// (the boundary's pressure, the wall velocity of the viscosity): two cells from the owned
// particle, so an owned particle's velocity update is exact when the values it reads are exact
// on the ghosts within 2 layers and their neighbours within 3. The pressure solves then iterate:
// each Jacobi iteration reads the neighbours' velocities the previous one wrote, and the ghosts
// whose velocities stay exact shrink by up to 3 layers an iteration (a rate reads a cell out, the
// update the boundary's kappa two cells more), up to max_iterations (10,000) times a step. No fixed
// depth covers that (a ghost layer 3 x 100 deep for a 100-iteration solve would hold the whole
// fluid), so instead every update of the velocities (each iteration of both solves, their warm
// starts and predict_velocity) is followed by a refresh of the ghosts' velocities from their owners
// (ghost_refresh.h: 12 bytes per ghost, one MPI_Alltoallv, the pattern fixed for the step since
// positions stay put until integrate). With every velocity exact again at the start of each
// iteration, 3 layers suffice, and dfsph sorts by the positions the exchange used: no slack.
constexpr int kPredictorReach = 3;
int GhostDepth(const std::string& solver, int time_integration) {
  if (solver == "seed") return 3 + 2;
  if (solver == "dfsph") return 3;
  return time_integration == 1 ? kPredictorReach + 2 : 2;
}

using Clock = std::chrono::steady_clock;

double MsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

}  // namespace

DistributedSimulation::DistributedSimulation(Scene scene, const Communicator& comm,
                                             const Device& device)
    : DistributedSimulation(std::move(scene), comm, device, nullptr) {}

DistributedSimulation::DistributedSimulation(Scene scene, const Communicator& comm,
                                             std::unique_ptr<StepBackend> device_backend)
    : DistributedSimulation(std::move(scene), comm, Device{}, std::move(device_backend)) {}

DistributedSimulation::DistributedSimulation(Scene scene, const Communicator& comm,
                                             const Device& device,
                                             std::unique_ptr<StepBackend> device_backend)
    : scene_(std::move(scene)),
      comm_(comm),
      device_(device),
      backend_(std::move(device_backend)),
      refreshes_ghosts_(scene_.solver == "dfsph") {
  solver_ = FindSolver(scene_.solver).create();
  Configure(scene_.params);
  set_balance(balancer_.settings());
  SpawnSlab();
  state_.share.max_over_processes = [this](std::span<double> v) {
    const auto start = Clock::now();
    comm_.MaxInPlace(v);
    collective_ms_ += MsSince(start);
  };
  state_.share.sum_over_processes = [this](std::span<int64_t> v) {
    const auto start = Clock::now();
    comm_.SumInPlace(v);
    collective_ms_ += MsSince(start);
  };
  if (refreshes_ghosts_ && backend_) {
    // On the device the passes refresh through the backend (ProcessShare::device_ghosts, set
    // for each device step).
    device_ghosts_ = std::make_unique<DeviceGhosts>(*this);
  } else if (refreshes_ghosts_) {
    state_.share.refresh_ghosts = [this](std::span<Vec3> v) {
      const auto start = Clock::now();
      totals_.bytes_sent += ghost_refresh_.Refresh(comm_, v);
      collective_ms_ += MsSince(start);
    };
  }
}

void DistributedSimulation::CheckSupported(const Scene& scene, const Params& params) {
  // A solver runs across processes once its passes' reads are covered by the ghost layers or
  // refreshed (GhostDepth) and the reductions that steer it are exact (ProcessShare): a new
  // solver is refused until then.
  if (scene.solver != "wcsph" && scene.solver != "seed" && scene.solver != "dfsph") {
    throw ConfigError("solver", "'" + scene.solver +
                                    "' does not run across processes yet; allowed: wcsph, seed, "
                                    "dfsph (run other solvers without mpirun)");
  }
  // Every parameter runs across processes, wcsph's predictor-corrector (time_integration 1) and
  // half-support cells (grid_cells_per_support 2: the slabs then count half-support layers)
  // included.
  (void)params;
}

void DistributedSimulation::CheckSupported(const Scene& scene, const Params& params,
                                           const Device& device) {
  CheckSupported(scene, params);
  if (!device.is_cuda()) return;
  // The device's step (distributed_device_step.cc) leaves the ghosts out of the reductions that
  // steer the step and takes the ownership from its last sort: wcsph (both time integrations),
  // the seed (by its predicted positions, a fixed step) and dfsph (its ghosts refreshed inside
  // the solves through the backend's hook, ProcessShare::device_ghosts). A solver added to the
  // ranks must be made to run there too, or be refused here.
  if (scene.solver != "wcsph" && scene.solver != "seed" && scene.solver != "dfsph") {
    throw ConfigError("solver", "'" + scene.solver +
                                    "' does not run on GPU ranks yet (--device cuda across "
                                    "processes runs wcsph, seed and dfsph); run it on CPU ranks "
                                    "(--device cpu)");
  }
}

void DistributedSimulation::SetParams(const Params& params) { Configure(params); }

void DistributedSimulation::set_balance(BalanceSettings settings) {
  settings.by_work = settings.by_work || backend_ != nullptr;
  balancer_.set_settings(settings);
}

void DistributedSimulation::Configure(const Params& params) {
  const SolverInfo& info = FindSolver(scene_.solver);
  CheckSupported(scene_, params, device_);
  BlockParticleCounts(scene_, params);
  model_ = MakeModel(scene_, params, info);
  passes_ = solver_->BuildPasses(model_);
  if (device_.is_cuda() && !backend_) {
    backend_ = CreateDeviceStepBackend(device_, scene_.solver);  // throws when it cannot run
    backend_->StageThroughPinnedMemory();
  }
  sort_pass_ = passes_.size();
  corrector_sort_pass_ = passes_.size();
  profile_.assign(1, {"exchange"});
  for (size_t k = 0; k < passes_.size(); ++k) {
    if (passes_[k].name == kNeighbourSortPass) sort_pass_ = k;
    // The predictor-corrector's second sort (wcsph's symplectic.h names it so).
    if (passes_[k].name == std::string(kNeighbourSortPass) + "_corrector") corrector_sort_pass_ = k;
    profile_.push_back({passes_[k].name});
  }
  profile_.push_back({"drop_ghosts"});
  if (sort_pass_ == passes_.size()) throw std::logic_error("the solver has no neighbour sort");
  if (backend_) {
    // The device's passes (the CPU solver's names) between the copies up and down.
    profile_.assign(1, {"exchange"});
    profile_.push_back({"upload"});
    for (const std::string& name : backend_->Configure(model_)) profile_.push_back({name});
    profile_.push_back({"download"});
    profile_.push_back({"drop_ghosts"});
  }

  // The layout every step sorts into (cell edge: the kernel support, the seed's smoothing radius).
  // The solver's own grid (its cells per support too): a layer is a cell plane of the grid the
  // passes read by, and the depths below, counted in supports, become that many layers each.
  layout_.Configure(model_.domain, Real(model_.kernel_support), model_.periodic,
                    model_.grid_cells_per_support);
  const Eigen::Vector3i dims = layout_.dims();
  axis_ = 0;
  for (int a = 1; a < 3; ++a) {
    if (dims[a] > dims[axis_]) axis_ = a;
  }
  ghost_depth_ = GhostDepth(scene_.solver, params.time_integration) * model_.grid_cells_per_support;
  slabs_ = std::make_unique<Slabs>(dims[axis_], comm_.size(), model_.periodic[axis_], ghost_depth_);
  // The boundary particles weigh in the cost estimate of each layer (balancer.h).
  boundary_per_layer_.assign(size_t(slabs_->layers()), 0);
  for (const Vec3& x : solver_->BoundaryPositions())
    ++boundary_per_layer_[layout_.CellOf(x)[axis_]];
  balancer_.Restart();
  last_compute_ms_ = -1;
}

DistributedSimulation::~DistributedSimulation() = default;

void DistributedSimulation::Adopt(ParticleArrays all, std::vector<SolverArray> arrays) {
  std::vector<int> layer(all.size());
  std::vector<int64_t> counts(size_t(slabs_->layers()), 0);
  for (size_t i = 0; i < all.size(); ++i) {
    layer[i] = layout_.CellOf(all.position[i])[axis_];
    ++counts[layer[i]];
  }
  slabs_->Balance(counts);
  balancer_.Restart();
  last_compute_ms_ = -1;
  std::vector<uint8_t> keep(all.size());
  keys_.clear();
  for (size_t i = 0; i < all.size(); ++i) {
    keep[i] = slabs_->OwnerOf(layer[i]) == comm_.rank();
    if (keep[i]) keys_.push_back(i);
  }
  total_ = keep.size();  // every process holds them all
  // Arrays of another size than the particles are cold starts, as in Solver::RestoreArrays.
  std::erase_if(arrays, [&](const SolverArray& a) { return a.values.size() != keep.size(); });
  KeepParticles(keep, all, arrays);
  state_.particles = std::move(all);
  state_.share.ghost.clear();
  solver_->RestoreArrays(arrays, state_.particles.size());
}

void DistributedSimulation::SpawnSlab() {
  // Every process walks the whole scene's spawn (deterministic) twice, storing none of it: once
  // to count each layer's particles, from which all cut the same slabs (Adopt's cuts), then to
  // keep its slab's. So a process holds O(N / P) particles from the start, not O(N). The spawn
  // index is their first order key, the order one process starts in.
  std::vector<int64_t> counts(size_t(slabs_->layers()), 0);
  total_ = VisitSpawnedParticles(scene_, model_.params, [&](uint32_t, const Vec3& x, const Vec3&) {
    ++counts[layout_.CellOf(x)[axis_]];
  });
  slabs_->Balance(counts);
  balancer_.Restart();
  last_compute_ms_ = -1;
  size_t owned = 0;
  for (int l = slabs_->begin(comm_.rank()); l < slabs_->begin(comm_.rank() + 1); ++l)
    owned += size_t(counts[size_t(l)]);
  ParticleArrays& mine = state_.particles;
  mine.Resize(owned);
  keys_.clear();
  keys_.reserve(owned);
  VisitSpawnedParticles(scene_, model_.params, [&](uint32_t id, const Vec3& x, const Vec3& v) {
    if (slabs_->OwnerOf(layout_.CellOf(x)[axis_]) != comm_.rank()) return;
    const size_t k = keys_.size();
    keys_.push_back(id);
    mine.id[k] = id;
    mine.position[k] = x;
    mine.velocity[k] = v;
  });
  std::fill(mine.density.begin(), mine.density.end(), Real(0));
  std::fill(mine.pressure.begin(), mine.pressure.end(), Real(0));
  state_.share.ghost.clear();
  solver_->RestoreArrays({}, mine.size());
}

void DistributedSimulation::Record(size_t pass, double ms) {
  PassProfile& prof = profile_[pass];
  prof.last_ms = ms;
  prof.total_ms += ms;
  ++prof.calls;
}

void DistributedSimulation::Step(double until) {
  if (!alarm_.empty()) return;
  const double start_time = state_.time;
  const double rest = until - start_time;
  if (model_.physical) {
    state_.max_dt = rest > 0 ? rest : std::numeric_limits<double>::infinity();
  } else {
    state_.dt = model_.dt;
  }
  bool finite = true;
  if (!RunStep(start_time, finite)) return;
  // As Simulation::Step: a step clamped to the cap lands on `until` itself.
  state_.time = model_.physical && state_.dt >= state_.max_dt ? until : start_time + state_.dt;
  ++state_.step;
  std::string alarm = DivergedStepAlarm(finite, state_, start_time);
  if (!alarm.empty()) alarm_ = std::move(alarm);
}

DistributedSimulation::StepOutcome DistributedSimulation::StepAt(double time, uint64_t step,
                                                                 double max_dt) {
  // The driver decides when to step again after an alarm (it restores or resets first), and
  // keeps the frame's warnings.
  alarm_.clear();
  state_.warning.clear();
  state_.time = time;
  state_.step = step;
  if (model_.physical) {
    state_.max_dt = max_dt;
  } else {
    state_.dt = model_.dt;
  }
  StepOutcome outcome;
  outcome.completed = RunStep(time, outcome.finite);
  outcome.dt = state_.dt;
  if (outcome.completed) {
    // The driver sets the time before the next step; this keeps time() meaningful meanwhile.
    state_.time = model_.physical && state_.dt >= state_.max_dt ? time + max_dt : time + state_.dt;
    ++state_.step;
  }
  return outcome;
}

bool DistributedSimulation::RunStep(double start_time, bool& finite) {
  if (backend_) return RunDeviceStep(start_time, finite);
  auto start = Clock::now();
  WaitAndExchange();
  Record(0, MsSince(start));
  // The compute time: the passes without the waits in their collectives (the CFL maxima).
  collective_ms_ = 0;
  double compute_ms = 0;
  for (size_t k = 0; k < passes_.size(); ++k) {
    start = Clock::now();
    passes_[k].run(model_, state_);
    const double ms = MsSince(start);
    Record(k + 1, ms);
    compute_ms += ms;
    if ((k == sort_pass_ || k == corrector_sort_pass_) &&
        !AfterSort(start_time, k == corrector_sort_pass_)) {
      return false;
    }
  }
  start = Clock::now();
  DropGhosts();
  Record(profile_.size() - 1, MsSince(start));
  FinishStep(compute_ms + profile_.back().last_ms, finite);
  return true;
}

void DistributedSimulation::FinishStep(double passes_ms, bool& finite) {
  const BalanceSettings& balance = balancer_.settings();
  double compute_ms = passes_ms;
  if (balance.slow_rank == comm_.rank() && balance.slow_us_per_particle > 0) {
    // Test-only: a deliberately slow process (BalanceSettings).
    const auto start = Clock::now();
    std::this_thread::sleep_for(std::chrono::duration<double, std::micro>(
        balance.slow_us_per_particle * double(state_.particles.size())));
    const double slept = MsSince(start);  // timed as a part of drop_ghosts
    profile_.back().last_ms += slept;
    profile_.back().total_ms += slept;
    compute_ms += slept;
  }
  compute_ms -= collective_ms_;
  // Never negative: a process that found its time < 0 would skip the balancer's step, and so
  // its collective at the end of the window, and the processes' collectives would mismatch
  // (collective_ms_ holds only waits timed inside the passes, so this is a guard).
  compute_ms = std::max(compute_ms, 0.0);
  last_compute_ms_ = compute_ms;
  totals_.compute_ms += compute_ms;
  double diverged = StateIsFinite(state_.particles) ? 0 : 1;
  comm_.MaxInPlace({&diverged, 1});
  finite = diverged == 0;
}

void DistributedSimulation::WaitAndExchange() {
  // The exchange's all-to-all would wait for the slowest process anyway; waiting first, in a
  // collective of 8 bytes, tells the exchange's own cost from the processes' imbalance.
  const auto start = Clock::now();
  double nothing = 0;
  comm_.MaxInPlace({&nothing, 1});
  totals_.wait_ms += MsSince(start);
  Exchange();
}

void DistributedSimulation::Exchange() {
  const ParticleArrays& p = state_.particles;
  const size_t n = p.size();
  std::vector<int> layer(n);
  std::vector<int64_t> counts(size_t(slabs_->layers()), 0);
  for (size_t i = 0; i < n; ++i) {
    layer[i] = layout_.CellOf(p.position[i])[axis_];
    ++counts[layer[i]];
  }
  // Re-balanced by the measured step times (balancer.h) when they drift apart: the latest
  // step's time spread over this slab's layers by their particles, fluid and boundary. Since the
  // order keys do not depend on where a particle lives, a re-cut changes no bit of the result.
  if (last_compute_ms_ >= 0) {
    // A layer's work: its fluid particles and, at an eighth of their weight, its boundary
    // particles (most are dry walls, read only where fluid is near: measured on the dam break,
    // a boundary particle costs a tenth of a fluid one or less).
    std::vector<int64_t> work(counts.size());
    for (size_t l = 0; l < counts.size(); ++l) work[l] = 8 * counts[l] + boundary_per_layer_[l];
    balancer_.Record(last_compute_ms_, *slabs_, comm_.rank(), work);
    if (balancer_.Rebalance(comm_, *slabs_)) ++totals_.recuts;
  }
  LocalParticles owned;
  owned.particles = std::move(state_.particles);
  owned.key = std::move(keys_);
  // The solver's per-particle arrays travel with the particles; one a process does not hold
  // for every particle (wcsph's carried density before the first step) is a cold start on all.
  std::vector<SolverArray> arrays = solver_->SaveArrays();
  std::vector<double> missing(arrays.size());
  for (size_t k = 0; k < arrays.size(); ++k) missing[k] = arrays[k].values.size() != n ? 1 : 0;
  comm_.MaxInPlace(missing);
  for (size_t k = 0; k < arrays.size(); ++k) {
    if (missing[k] == 0) owned.arrays.push_back(std::move(arrays[k]));
  }
  ExchangeCounts moved;
  LocalParticles mine = ExchangeParticles(comm_, *slabs_, layer, std::move(owned), moved);
  totals_.migrated += moved.migrated;
  totals_.ghosts += moved.ghosts;
  totals_.bytes_sent += moved.bytes_sent;
  state_.particles = std::move(mine.particles);
  state_.share.ghost = std::move(mine.ghost);
  solver_->RestoreArrays(mine.arrays, state_.particles.size());
}

bool DistributedSimulation::AfterSort(double start_time, bool second) {
  const NeighborGrid& grid = state_.grid;
  const size_t n = state_.particles.size();
  const bool predictor = corrector_sort_pass_ < passes_.size();
  // The predictor-corrector's half step must move no particle more than one layer (the ghosts'
  // slack): compared between the two sorts, on every particle this process holds (each is held
  // where it was owned at t, so every particle is checked somewhere).
  double moved = 0;
  if (predictor && second) {
    PermuteInPlace(grid.order(), first_layer_, index_scratch_);
    const int layers = slabs_->layers();
    for (size_t k = 0; k < n; ++k) {
      int d = std::abs(grid.SortedCell(uint32_t(k))[axis_] - first_layer_[k]);
      if (model_.periodic[axis_]) d = std::min(d, layers - d);
      moved = std::max(moved, double(d));
    }
  } else if (predictor) {
    first_layer_.resize(n);
    for (size_t k = 0; k < n; ++k) first_layer_[k] = grid.SortedCell(uint32_t(k))[axis_];
  }
  // The sort reordered the particles, by the positions the solver sorts with (the seed's
  // predicted ones): a particle is owned where its sorted cell lies, a ghost elsewhere. Each
  // must be owned by exactly one process, which holds when the sort's positions stay within
  // the ghost layers' slack of the exchange's.
  std::vector<uint8_t>& ghost = state_.share.ghost;
  ghost.assign(n, 0);
  int64_t owned = 0;
  for (size_t k = 0; k < n; ++k) {
    // 0: owned; a ghost: its distance in layers from this slab (ProcessShare::ghost).
    ghost[k] =
        uint8_t(std::min(255, slabs_->Distance(grid.SortedCell(uint32_t(k))[axis_], comm_.rank())));
    owned += ghost[k] ? 0 : 1;
  }
  comm_.SumInPlace({&owned, 1});
  double maxima[2] = {double(grid.max_cell_count()), moved};
  comm_.MaxInPlace(maxima);
  const double crowded = maxima[0];
  // Between the predictor-corrector's sorts, the ghosts within kPredictorReach compute their
  // rates (their predicted state is read after the second sort), and the boundary particles
  // within a layer of those; after it, as after the only sort of the other schemes.
  const int per_support = model_.grid_cells_per_support;  // layers a support spans
  const int reach = predictor && !second ? kPredictorReach * per_support : 0;
  state_.share.rate_reach = uint8_t(reach);
  state_.share.layer_axis = axis_;
  state_.share.boundary_layers.resize(size_t(slabs_->layers()));
  for (int l = 0; l < slabs_->layers(); ++l) {
    state_.share.boundary_layers[l] =
        slabs_->Distance(l, comm_.rank()) <= reach + per_support ? 1 : 0;
  }
  if (maxima[1] > per_support) {
    alarm_ = MovedAlarm(int(maxima[1]), start_time);
  } else if (uint64_t(owned) != total_) {
    alarm_ = OwnerAlarm(owned, start_time);
  } else if (crowded > NeighborGrid::kMaxParticlesPerCell) {
    alarm_ = CrowdedAlarm(uint64_t(crowded), start_time);
  } else {
    // Outside the passes' timing, as the collectives above: not in collective_ms_, which is
    // taken off the passes' time.
    if (refreshes_ghosts_) {
      std::vector<int>& layer = index_scratch_;
      layer.resize(n);
      for (size_t k = 0; k < n; ++k) layer[k] = grid.SortedCell(uint32_t(k))[axis_];
      ghost_refresh_.Plan(comm_, *slabs_, layer, ghost, state_.particles.id);
    }
    return true;
  }
  DropGhosts();
  return false;
}

std::string DistributedSimulation::OwnerAlarm(int64_t owned, double start_time) const {
  return std::to_string(owned) + " of " + std::to_string(total_) +
         " particles found an owner at step " + std::to_string(state_.step + 1) +
         " (t = " + std::to_string(start_time) +
         " s): a particle's sorted position moved past the ghost layers (" +
         std::to_string(ghost_depth_) + " cells) from where it was exchanged";
}

std::string DistributedSimulation::MovedAlarm(int layers, double start_time) const {
  return "a particle moved " + std::to_string(layers) +
         " cell layers in the predictor's half step at step " + std::to_string(state_.step + 1) +
         " (t = " + std::to_string(start_time) +
         " s), past the ghost layers' slack of one kernel support (" +
         std::to_string(model_.grid_cells_per_support) + " layers): reduce the time step";
}

std::string DistributedSimulation::CrowdedAlarm(uint64_t count, double start_time) const {
  return std::to_string(count) + " particles crowd one neighbour-grid cell at step " +
         std::to_string(state_.step + 1) + " (t = " + std::to_string(start_time) + " s; at most " +
         std::to_string(NeighborGrid::kMaxParticlesPerCell) +
         " can, or each step costs O(n^2)): the fluid collapsed";
}

void DistributedSimulation::DropGhosts() {
  const size_t n = state_.particles.size();
  std::vector<uint64_t> keys = OrderKeys(state_.grid, n);
  const std::vector<uint8_t>& ghost = state_.share.ghost;
  if (std::none_of(ghost.begin(), ghost.end(), [](uint8_t g) { return g != 0; })) {
    // No ghost to drop (one process, or a slab no other borders): every particle and array
    // stays as it is (the copies below took 88 ms a step at 1 M particles on one rank).
    keys_ = std::move(keys);
    state_.share.ghost.clear();
    return;
  }
  std::vector<uint8_t> keep(n);
  keys_.clear();
  keys_.reserve(n);
  for (size_t k = 0; k < n; ++k) {
    keep[k] = !state_.share.IsGhost(k);
    if (keep[k]) keys_.push_back(keys[k]);
  }
  std::vector<SolverArray> arrays = solver_->SaveArrays();
  KeepParticles(keep, state_.particles, arrays);
  solver_->RestoreArrays(arrays, state_.particles.size());
  state_.share.ghost.clear();
}

uint64_t DistributedSimulation::TotalParticles() const {
  int64_t n = int64_t(state_.particles.size());
  comm_.SumInPlace({&n, 1});
  return uint64_t(n);
}

}  // namespace dysa::distributed
