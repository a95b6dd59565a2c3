// One simulation spread over the processes of a Communicator by slabs of whole grid cells
// (slabs.h), giving the same bits at any process count as dysa::Simulation on one.
//
// A step on each process: re-cut the slabs when the processes' measured step times drift apart
// (balancer.h; the first cuts balance the particle counts), send each owned particle to the owner
// of its layer (migration) and a copy to the processes that hold its layer as ghosts, sort by order
// key (particle_exchange.h), then run the solver's own passes unchanged over owned particles and
// ghosts alike; the CFL step's maxima skip the ghosts and combine over the processes
// (State::share). Ghosts reach deep enough (2 layers for wcsph, 5 for the seed) that every value an
// owned particle reads is computed locally from exact inputs and one exchange per step suffices;
// dfsph's solves iterate on their neighbours' velocities, so its ghosts (3 layers) take their
// owners' velocities again after every update (ghost_refresh.h). After the passes the ghosts are
// dropped.
//
// Supported: wcsph with symplectic Euler (time_integration 0) and the predictor-corrector
// (1: ghosts 5 layers deep, those within 3 computing the predictor's interactions, flagged again
// after the second sort), with walls, static and moving obstacles, periodic axes, viscosity,
// density diffusion and particle shifting; seed; dfsph (ghosts 3 layers deep, their velocities
// refreshed from their owners after every velocity update inside the step: ghost_refresh.h; its
// stopping tests' mean errors summed as fixed-point integers over the processes).
//
// On a GPU (a CUDA `device`: distributed_device_step.cc) each step's exchange stays on the host
// as above; then the owned particles and ghosts, in key order, go up to the device through
// page-locked buffers, the solver's CUDA pipeline steps them all (its stable sort by cell gives
// the CPU's order), its CFL maxima skipping the ghosts (by the cell layers this process owns,
// ProcessShare::owned_layers) and combined over the processes before dt is chosen, and they come
// back; the cells of the device's (last) sort give the ghost flags and the order keys, and the
// ghosts are dropped. Supported there: wcsph (both time integrations), the seed and dfsph, whose
// ghosts' refresh and combined mean errors go through the backend's hook
// (ProcessShare::device_ghosts, DeviceGhosts).
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "dysa/core/device.h"
#include "dysa/core/model.h"
#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "dysa/core/solver.h"
#include "dysa/core/state.h"
#include "dysa/core/step_backend.h"
#include "dysa/core/view_selection.h"
#include "dysa/distributed/balancer.h"
#include "dysa/distributed/communicator.h"
#include "dysa/distributed/ghost_refresh.h"
#include "dysa/distributed/particle_exchange.h"
#include "dysa/distributed/slabs.h"

namespace dysa::distributed {

// Which per-particle arrays a read by ids or a view's subset sends (GatherParticlesByIds,
// SelectViewSubset): a combination of these bits; the id always goes.
enum ReadFields : uint32_t { kReadPosition = 1, kReadVelocity = 2, kReadDensity = 4 };

// A view stream's subset on process 0 (SelectViewSubset): the chosen ids, increasing, and their
// particles in that order (id and the asked arrays; the others empty).
struct GatheredViewSubset {
  std::vector<uint32_t> ids;
  ParticleArrays particles;
};

// What this process exchanged since the start.
struct ExchangeTotals {
  uint64_t migrated = 0;  // particles that left this process for another
  uint64_t ghosts = 0;    // ghosts received, summed over steps
  uint64_t bytes_sent = 0;
  uint64_t recuts = 0;    // steps whose re-balance moved a cut (the same on every process)
  double compute_ms = 0;  // this process's compute time in its steps (no waits in collectives)
  // Of the exchange pass's time: waiting for the other processes to end their step (the
  // imbalance; the rest is the exchange's own packing, transfer and sorting).
  double wait_ms = 0;
};

class DistributedSimulation {
 public:
  // Collective. Validates the scene (ConfigError) and what runs across processes so far
  // (wcsph, seed, dfsph: ConfigError naming "solver"), spawns its particles and
  // keeps those of this process's slab. `comm` must outlive this. With a CUDA `device` the
  // steps run there (what runs: CheckSupported; ConfigError("device", ...) when it cannot run).
  DistributedSimulation(Scene scene, const Communicator& comm, const Device& device = {});
  // As above with `device_backend` standing in for a GPU's backend: the device path of the step
  // without a GPU (tests/distributed/host_device_backend.h).
  DistributedSimulation(Scene scene, const Communicator& comm,
                        std::unique_ptr<StepBackend> device_backend);
  ~DistributedSimulation();

  const Scene& scene() const { return scene_; }
  const Model& model() const { return model_; }
  const Communicator& comm() const { return comm_; }
  const Slabs& slabs() const { return *slabs_; }
  // The grid axis the slabs cut (the one with the most cells).
  int axis() const { return axis_; }
  double time() const { return state_.time; }
  uint64_t step() const { return state_.step; }
  double last_dt() const { return state_.dt; }
  // The particles this process owns between steps.
  const ParticleArrays& particles() const { return state_.particles; }
  const ExchangeTotals& totals() const { return totals_; }
  // The step-time balance (balancer.h): its settings (the same on every process) and what it saw.
  // On GPU ranks (a device step backend) the balance is by work (BalanceSettings::by_work).
  void set_balance(BalanceSettings settings);
  const BalanceReport& balance() const { return balancer_.report(); }
  // Per pass, with "exchange" first and "drop_ghosts" last: this process's time. The exchange's
  // includes the wait for the others (ExchangeTotals::wait_ms).
  const std::vector<PassProfile>& profile() const { return profile_; }
  // As Simulation::alarm; the same on every process.
  const std::string& alarm() const { return alarm_; }
  // What the latest StepAt's passes warned of (State::warning; empty: nothing). A physical
  // solver's warnings come from the maxima over the processes: the same on every process.
  const std::string& warning() const { return state_.warning; }

  // Collective. One step, as Simulation::Step(until).
  void Step(double until = std::numeric_limits<double>::infinity());
  // Collective. One step for a driver that keeps the clock (dysa::Simulation on process 0 with
  // the ranks' backend, which sends every process its time, step counter and cap): from `time`
  // and `step`, a physical solver's step capped at `max_dt`, a fixed step of the model's dt.
  // What Step(until) computes for the same state when Simulation::Step(until) passes that cap.
  struct StepOutcome {
    bool completed = true;  // false: stopped after the neighbour sort, alarm() says why
    bool finite = true;     // every particle finite afterwards (on every process)
    double dt = 0;          // the step taken
  };
  StepOutcome StepAt(double time, uint64_t step, double max_dt);
  // Collective in effect (every process must apply the same): new parameters, validated as by
  // the constructor, keeping the particles (Simulation::SetParams without a reset).
  void SetParams(const Params& params);
  // Throws ConfigError naming the field ("solver") when `scene` with
  // `params` cannot run across processes yet.
  static void CheckSupported(const Scene& scene, const Params& params);
  // The same on `device`: on a GPU also ConfigError naming "solver" for a solver the device's
  // step does not run (every one the ranks run does: wcsph, seed, dfsph).
  static void CheckSupported(const Scene& scene, const Params& params, const Device& device);
  const Device& device() const { return device_; }
  // Collective. The particles of all processes.
  uint64_t TotalParticles() const;
  // Collective. Every process's particles on process 0, in the storage order one process would
  // have (order key), so that a probe or a frame sums and writes them as one process would;
  // empty elsewhere.
  ParticleArrays GatherParticles() const;
  // Collective. As GatherParticles, only the particles of BelowRank(id, threshold) (threshold >
  // 0; dysa/detail_rank.h): each process chooses its own, so only they cross to process 0.
  ParticleArrays GatherParticlesBelowRank(uint32_t threshold) const;
  // The reads of a view stream (a camera) on the ranks (distributed_view_reads.cc): each process
  // sends only what was asked of its own particles, so what crosses scales with the view, not
  // with the simulation.
  //
  // Collective: every process passes the same `ids` (each below the particle count) and
  // `fields` (ReadFields bits). Process 0 gets those particles in the order of `ids` (id and
  // the asked arrays, bit for bit one process's); each process sends only the asked particles
  // it owns (4 bytes of id plus the asked arrays each). Empty elsewhere.
  ParticleArrays GatherParticlesByIds(std::span<const uint32_t> ids, uint32_t fields) const;
  // Collective. On process 0 per axis the smallest and largest position of every particle, as
  // Simulation::ReadPositionBounds gives them on one process (a NaN skipped; a zero extreme
  // signed as the first zero in one process's storage order; lo +inf and hi -inf without
  // particles); default-constructed elsewhere. Each process sends 60 bytes: per axis its
  // extremes and its first zero (order key and sign).
  Simulation::PositionBounds PositionBounds() const;
  // Collective: every process passes the same box, stride, `budget` and `fields`; only process
  // 0's request.weigh is called (once), the others' may be empty. On process 0 the ids
  // ViewKeys(every particle, request).Select(budget) chooses on one process, and their asked
  // arrays; empty elsewhere. Each process sends its candidates' non-empty view cells (8 bytes
  // each) and gets their weights back, then its min(budget, own candidates) smallest (key, id)
  // pairs (8 bytes each; none when the budget takes every candidate), and finally only its
  // chosen particles.
  GatheredViewSubset SelectViewSubset(const ViewSubsetRequest& request, uint64_t budget,
                                      uint32_t fields) const;
  // Collective. On process 0 the checkpoint one process's Simulation::SaveCheckpoint gives for
  // this state (its particles and solver arrays in that process's storage order), so that it
  // restores on any number of processes; empty elsewhere. Its frame is the one restored last.
  Checkpoint SaveCheckpoint() const;
  // Collective: every process passes the same checkpoint, of this scene, taken on any number of
  // processes or by Simulation. Restores its parameters (validated as by the constructor),
  // particles, solver arrays, time and step, and re-cuts the slabs; the next steps give the
  // bits they give after Simulation::RestoreCheckpoint.
  void RestoreCheckpoint(const Checkpoint& checkpoint);
  // Collective. StateHash of the whole simulation on process 0 (the value one process's
  // Simulation gives for the same state); 0 elsewhere.
  uint64_t GlobalStateHash() const;

 private:
  DistributedSimulation(Scene scene, const Communicator& comm, const Device& device,
                        std::unique_ptr<StepBackend> device_backend);
  // The exchange, the passes and the dropping of the ghosts of one step from state_.time (cap
  // and dt set); false when the sort found the state unfit to go on (alarm_ set).
  bool RunStep(double start_time, bool& finite);
  void Exchange();
  // RunStep on the device (distributed_device_step.cc).
  bool RunDeviceStep(double start_time, bool& finite);
  // The compute time of the step just run (`passes_ms` less the waits in the collectives inside
  // them) for the balance, after the test-only slow-down (BalanceSettings); then the
  // finiteness of the particles over the processes into `finite`.
  void FinishStep(double passes_ms, bool& finite);
  // The exchange pass: waits for every process to end its step (timed into totals_.wait_ms),
  // then Exchange().
  void WaitAndExchange();
  // AfterSort's alarms: a cell holding `count` particles; `owned` of the particles owned.
  std::string CrowdedAlarm(uint64_t count, double start_time) const;
  std::string OwnerAlarm(int64_t owned, double start_time) const;
  std::string MovedAlarm(int layers, double start_time) const;
  // The most cell layers (along the slab axis) a particle held here moved between the device's
  // two sorts of the predictor-corrector (0 for a step that sorted once).
  int DeviceHalfStepMove() const;
  // After the neighbour sort: the ghost flags in sorted order and the cells' occupancy.
  // `second`: the predictor-corrector's second sort (by the positions at t + dt/2).
  bool AfterSort(double start_time, bool second);
  // After the passes: order keys for the next step, then the ghosts dropped.
  void DropGhosts();
  void Record(size_t pass, double ms);
  // Checks the model can run across processes and builds its passes and grid layout.
  void Configure(const Params& params);
  // Keeps, of `all` (every process's particles in one process's storage order, which becomes
  // their order key) and their solver arrays, those of this process's slab after a re-cut.
  void Adopt(ParticleArrays all, std::vector<SolverArray> arrays);
  // The scene's particles of this process's slab, spawned (the constructor).
  void SpawnSlab();
  // Collective: every process's particles (and with `arrays`, the solver's arrays) on process 0
  // in key order.
  // With a `threshold`, only the particles of BelowRank(id, threshold) (no arrays).
  LocalParticles GatherAll(bool arrays, uint32_t threshold = 0) const;

  Scene scene_;
  const Communicator& comm_;
  Device device_;
  // The device's backend (null on the CPU) and the cells of its latest sort.
  std::unique_ptr<StepBackend> backend_;
  std::vector<uint32_t> sorted_cells_;
  Model model_;
  std::unique_ptr<Solver> solver_;
  std::vector<Pass> passes_;
  size_t sort_pass_ = 0;
  size_t corrector_sort_pass_ = 0;  // passes_.size(): none (symplectic Euler, seed)
  int ghost_depth_ = 2;
  // dfsph: the ghosts' velocities are refreshed from their owners inside the step
  // (ghost_refresh.h), along the pattern planned after each sort.
  bool refreshes_ghosts_ = false;
  GhostRefresh ghost_refresh_;
  // The same refresh for the device's step (ProcessShare::device_ghosts): its plan from the
  // device's sorted cells, replayed on the values the device reads back
  // (distributed_device_step.cc). Null on the CPU and for solvers that do not refresh.
  class DeviceGhosts;
  std::unique_ptr<DeviceGhosts> device_ghosts_;
  std::vector<int> first_layer_;  // per particle, its layer at the first sort (predictor)
  std::vector<int> index_scratch_;
  State state_;
  uint64_t total_ = 0;          // particles over all processes
  std::vector<uint64_t> keys_;  // order keys of the owned particles, storage order
  NeighborGrid layout_;         // the solver's grid layout, for the particles' layers
  int axis_ = 0;
  std::unique_ptr<Slabs> slabs_;
  ExchangeTotals totals_;
  Balancer balancer_;
  std::vector<int64_t> boundary_per_layer_;  // the solver's boundary particles per layer
  double last_compute_ms_ = -1;              // the latest step's compute time; < 0: none yet
  double collective_ms_ = 0;                 // time in collectives inside the passes
  std::vector<PassProfile> profile_;
  std::string alarm_;
};

}  // namespace dysa::distributed
