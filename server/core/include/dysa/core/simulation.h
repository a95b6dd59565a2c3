// A running simulation: scene, parameters, state, the pass list of the step and its profile.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "dysa/core/device.h"
#include "dysa/core/model.h"
#include "dysa/core/scene.h"
#include "dysa/core/solver.h"
#include "dysa/core/state.h"
#include "dysa/core/step_backend.h"

namespace dysa {

struct ViewSubsetRequest;  // dysa/core/view_selection.h

// Time spent in one pass, in milliseconds: wall time on the CPU, the time between CUDA events
// around the pass's kernels on a GPU.
struct PassProfile {
  std::string name;
  double last_ms = 0;   // the latest step
  double total_ms = 0;  // since the last ResetProfile()
  uint64_t calls = 0;
};

// Everything a simulation needs to carry on from a given moment, bit for bit: the parameters
// and the particles' ids, positions and velocities in storage order (the order decides the next
// neighbour sort, so restoring it reproduces the following steps exactly), and the arrays the
// solver carries from step to step (Solver::SaveArrays: dfsph's warm start; none for the
// others). Every other per-particle array is recomputed by the step before it is read.
struct Checkpoint {
  Params params;
  double time = 0;
  uint64_t step = 0;
  uint64_t frame = 0;
  std::vector<uint32_t> id;
  std::vector<Vec3> position;
  std::vector<Vec3> velocity;
  std::vector<SolverArray> solver_arrays;

  size_t bytes() const;
};

class Simulation {
 public:
  // Validates the scene (throws ConfigError) and spawns its particles. On a CUDA device the
  // particles live in GPU memory and every step runs there; throws ConfigError("device", ...)
  // when the device cannot run (naming what is missing) or the solver has no GPU backend.
  explicit Simulation(Scene scene, const Device& device = {});
  // Makes the backend a simulation steps on, for its scene (validated when it is called).
  using BackendFactory = std::function<std::unique_ptr<StepBackend>(const Scene&)>;
  // Steps on the backend `make` returns (the ranks of several processes: ranks_backend.h)
  // instead of the CPU's passes or the device's; `device` stays what device() says.
  Simulation(Scene scene, const Device& device, const BackendFactory& make);
  ~Simulation();
  Simulation(Simulation&&) noexcept;
  Simulation& operator=(Simulation&&) noexcept;

  const Scene& scene() const { return scene_; }
  const Params& params() const { return model_.params; }
  const Model& model() const { return model_; }
  // The whole state. On a GPU its particle arrays are a host copy, refreshed from device memory
  // by this call when a step ran since the last one (a copy of every array: read it per frame,
  // not per step; time(), step(), frame() and particle_count() cost nothing).
  const State& state() const;
  double time() const { return state_.time; }
  uint64_t step() const { return state_.step; }
  uint64_t frame() const { return state_.frame; }
  size_t particle_count() const { return particle_count_; }
  std::span<const PassProfile> profile() const { return profile_; }
  std::vector<std::string> PassNames() const;
  // The latest step's solver diagnostics (iterations, errors of an iterative solver), on any
  // device.
  SolverStats solver_stats() const;
  // The CPU's solver and, through its type (solvers/*), its own data: for tests and
  // diagnostics. Null on a GPU (or another backend), whose backend keeps that data.
  const Solver* solver() const { return backend_ ? nullptr : solver_.get(); }

  // Per-particle arrays in particle-id order (id k at index k): each span is empty (not read),
  // or 3 * particle_count() floats (positions, velocities: x, y, z interleaved), or
  // particle_count() floats (densities).
  struct ParticlesById {
    std::span<float> position;  // m
    std::span<float> velocity;  // m/s
    std::span<float> density;   // kg/m^3
  };
  // Copies the asked arrays of the current state into `out`, in id order: what a frame needs.
  // On a GPU only those arrays cross to the host, ordered by id there; the host copy behind
  // state() is neither read nor refreshed. Throws std::invalid_argument for a span of the wrong
  // size.
  void ReadParticlesById(const ParticlesById& out) const;
  // The same for a level of detail's subset: only the particles of BelowRank(id, threshold)
  // (dysa/detail_rank.h, the codec's detail threshold) are written, at their ids' entries; the
  // other entries are left as they are. A threshold of 0 keeps every particle, as the codec's
  // (ReadParticlesById). On a GPU the subset is chosen and packed on the device and only its
  // particles cross to the host; on ranks each rank sends only its particles of the subset.
  // Returns the particles written. Throws as ReadParticlesById.
  size_t ReadParticlesByIdBelowRank(uint32_t threshold, const ParticlesById& out) const;
  // A view stream's subset (dysa/core/view_selection.h): the ids of the `budget` smallest keys
  // of `request` on the current state, increasing, into `ids` (every candidate when budget >=
  // the candidates), and the asked arrays of those particles at their ids' entries of `out`; the
  // other entries are left as they are. The same ids on any device: on a GPU they are chosen and
  // packed on the device, and only the chosen particles, the grid's per-cell counts (to the
  // host, for request.weigh) and weights (back) cross; on the CPU ViewKeys chooses them; on
  // ranks each rank keys its own candidates and sends only its cells' counts, its part of the
  // budget's smallest keys and then its chosen particles (StepBackend::SelectViewSubset).
  // Returns ids.size(). Throws as ReadParticlesById, and std::invalid_argument without a weigher.
  size_t ReadViewSubset(const ViewSubsetRequest& request, uint64_t budget,
                        std::vector<uint32_t>& ids, const ParticlesById& out) const;
  // The particles `ids` (each below particle_count(), none twice, any order): their asked arrays
  // at their ids' entries of `out`, the others left as they are. What a view stream sends between
  // two selections (the ids it kept), so that a frame reads what it sends, not every particle. On
  // the CPU a scan of the storage's ids (the copy is what costs); on a GPU a gather on the device
  // (cuda/view_reads.cuh): only the ids' particles cross; on ranks each rank sends only the
  // asked particles it owns (StepBackend::GatherByIds). Returns ids.size(). Throws as
  // ReadParticlesById, and std::out_of_range for an id past the particles (nothing written).
  size_t ReadParticlesByIds(std::span<const uint32_t> ids, const ParticlesById& out) const;
  // Per axis the smallest and largest position of every particle, as floats (NaN skipped, as
  // std::min and std::max skip it; a zero extreme signed as the first zero in storage order, as
  // a sequential scan's); lo +inf and hi -inf without particles. The codec quantises a view
  // stream's keyframe over every particle's extremes (WidenPositionsToAll): this lets a frame that
  // reads only the sent particles pass them on. On a GPU reduced on the device, the same bits; on
  // ranks each rank reduces its own and rank 0 combines them (StepBackend::ReducePositionBounds).
  struct PositionBounds {
    std::array<float, 3> lo{}, hi{};
  };
  PositionBounds ReadPositionBounds() const;
  // The values of `probes` for the current state, in ProbeColumns() order (probes.h), as
  // EvaluateProbes(probes, model(), state()) computes them. On a GPU they are evaluated on the
  // device, which sends back only the particles around each local probe and the sums, not the
  // state: cheap enough to call every step.
  std::vector<double> EvaluateProbes(std::span<const ProbeSpec> probes) const;

  const Device& device() const { return device_; }
  // "cpu", or the GPU: "cuda:0 NVIDIA H200, 139.8 GiB, sm_90".
  std::string DeviceDescription() const;
  // GPU memory the simulation holds, bytes (0 on the CPU).
  uint64_t DeviceBytes() const;

  // One solver step: model().dt simulated seconds for a fixed-step solver (the seed); for a
  // physical solver the CFL step its time_step pass picks, never past `until` (s, simulated):
  // a step that reaches it ends exactly at `until`. Fixed-step solvers ignore `until`.
  void Step(double until = std::numeric_limits<double>::infinity());
  // One displayed frame. Fixed step: iterations_per_frame steps, as in the thesis. Physical
  // solvers: as many adaptive steps as it takes to advance exactly model().FrameTime().
  void StepFrame();
  // The same frame in pieces: steps until the frame is complete (then frame() counts it and it
  // returns true), or returns false between two steps once `interrupted()` (asked before every
  // step but the call's first, so each call makes progress) says so. The next call resumes that
  // frame: the same end time for a physical solver, the steps still owed for a fixed step, so a
  // frame stepped in any number of pieces ends in the same state as StepFrame(). A parameter
  // change that needs no reset leaves the frame's end as it was; Reset(), RestoreCheckpoint() and
  // a change that resets drop a partial frame.
  bool StepFrame(const std::function<bool()>& interrupted);
  // A frame was begun by StepFrame(interrupted) and not completed: the state lies between frame()
  // and the next.
  bool frame_in_progress() const { return frame_open_; }
  // The steps the frame in progress still owes: exact for a fixed step, estimated from the
  // latest step's length for a physical solver (its CFL step changes); 0 with no frame open.
  double FrameStepsLeft() const;
  // The step the latest Step() took, s.
  double last_dt() const { return state_.dt; }
  // Empty while the state is healthy. Otherwise why the simulation stopped by itself: a NaN or
  // Inf in a position or velocity after a step, an adaptive step that collapsed to zero, or
  // particles crowded into one neighbour-grid cell beyond NeighborGrid::kMaxParticlesPerCell,
  // found by the neighbour sort: the CPU stops before the passes that would cost O(n^2), a GPU
  // after the sort's first neighbour pass (wcsph, dfsph) or after the step (seed).
  // Step() and StepFrame() then do nothing (nothing integrates or shows garbage) until Reset(),
  // RestoreCheckpoint() or a parameter change that resets.
  const std::string& alarm() const { return alarm_; }
  // Empty unless a step of the latest frame (or of the Step() calls since it) could not hold the
  // solver's accuracy and limited it: which limit, how often, and why. The run goes on.
  const std::string& warning() const { return state_.warning; }
  // Re-spawns the particles from the scene with the current parameters; time and step go to 0.
  void Reset();

  // Validates and applies one parameter; rebuilds the pass list. Returns true if the change
  // needed a reset and the simulation was reset. Throws ConfigError (nothing applied).
  bool SetParam(std::string_view name, double value);
  // Applies a whole parameter set at once, all validated before any is applied.
  bool SetParams(const Params& params);

  // Saves the state the next steps depend on; RestoreCheckpoint(SaveCheckpoint()) followed by
  // the same steps gives bit-identical states.
  Checkpoint SaveCheckpoint() const;
  // The same into `into`, whose particle arrays keep their memory: a checkpoint taken every
  // frame (FrameStepper's frame start) then writes into pages it already has instead of fresh
  // ones (millions of particles: hundreds of MB a frame).
  void SaveCheckpoint(Checkpoint& into) const;
  // Restores particles, time, step, frame and the checkpoint's parameters (the pass list is
  // rebuilt for them). The checkpoint must come from this simulation's scene.
  void RestoreCheckpoint(const Checkpoint& checkpoint);

  void ResetProfile();

 private:
  void Rebuild();
  void RecordPassTime(size_t pass, double ms);
  // The alarm of a step whose neighbour sort found `count` particles in one cell.
  std::string CrowdedAlarm(uint32_t count, double start_time) const;
  // After a step: the alarm when it diverged, from `finite` and the step's dt.
  void CheckStep(bool finite, double start_time);
  // The particles changed on the host (spawn, restore): hand them and the solver's arrays
  // (none: a cold start) to the GPU.
  void UploadParticles(std::span<const SolverArray> solver_arrays = {});

  Scene scene_;
  Device device_;
  Model model_;
  // On a GPU the particle arrays are a cache of device memory (state()), hence mutable.
  mutable State state_;
  mutable bool host_stale_ = false;
  size_t particle_count_ = 0;
  const SolverInfo* solver_info_ = nullptr;  // the scene's solver, looked up once
  std::unique_ptr<Solver> solver_;
  std::unique_ptr<StepBackend> backend_;  // null on the CPU
  std::vector<Pass> passes_;              // the CPU's passes (empty on a GPU)
  // The neighbour sort among passes_ (after it the step checks the cells' occupancy), or
  // passes_.size() when there is none.
  size_t sort_pass_ = 0;
  std::vector<PassProfile> profile_;
  std::string alarm_;
  // The frame StepFrame is advancing, while frame_open_: where a physical solver's frame ends
  // (s) or how many fixed steps it still owes.
  bool frame_open_ = false;
  double frame_end_time_ = 0;
  int frame_steps_left_ = 0;
};

// Creates the particles of every fluid block (positions, velocities, ids) from the scene and
// parameters; deterministic for a given scene, parameters and seeds.
void SpawnParticles(const Scene& scene, const Params& params, ParticleArrays& particles);

// The particles SpawnParticles creates, one call each in spawn order, without storing them:
// visit(id, position, velocity) with id = the particle's index. For a process that keeps only
// part of them (server/distributed). Returns how many there were.
uint64_t VisitSpawnedParticles(
    const Scene& scene, const Params& params,
    const std::function<void(uint32_t id, const Vec3& position, const Vec3& velocity)>& visit);

// Half the smallest rest spacing of the particles `scene` spawns with `params`, in m: over every
// block and axis with more than one particle, the block's spacing, or size / (n - 1) for the
// thesis's edge-to-edge spawner. When no block has two particles along any axis, half the
// smoothing radius. Throws ConfigError as BlockParticleCounts.
double SpawnParticleRadius(const Scene& scene, const Params& params);

// The alarm of a step that began at `start_time` and left `state` (its step counter advanced):
// it diverged (`finite` false) or its time step collapsed; empty when neither. Simulation and
// the ranks' driver raise the same text.
std::string DivergedStepAlarm(bool finite, const State& state, double start_time);

}  // namespace dysa
