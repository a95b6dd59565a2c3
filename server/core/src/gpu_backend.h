// A solver's step on a GPU, behind the narrow interface Simulation uses: the particles live in
// device memory between steps and cross to the host only when read (frames, checkpoints,
// probes, status) or replaced (reset, restore).
#pragma once

#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "dysa/core/device.h"
#include "dysa/core/model.h"
#include "dysa/core/solver.h"
#include "dysa/core/state.h"
#include "probe_gather.h"
#include "rank_subset.h"

namespace dysa {

class GpuBackend {
 public:
  virtual ~GpuBackend() = default;

  const DeviceInfo& info() const { return info_; }

  // Sets up the passes of `model` (rebuilt whenever parameters change) and returns their
  // names, the CPU solver's.
  virtual std::vector<std::string> Configure(const Model& model) = 0;
  // Replaces the device's particles with `particles` (ids, positions, velocities) and the
  // solver's carried arrays with `solver_arrays` (Solver::SaveArrays's; a missing one starts
  // cold).
  virtual void Upload(const ParticleArrays& particles,
                      std::span<const SolverArray> solver_arrays) = 0;
  // Copies every shared per-particle array (ParticleArrays) back into `particles` (resized).
  virtual void Download(ParticleArrays& particles) const = 0;
  // Only what a checkpoint holds: ids, positions, velocities and the solver's carried arrays,
  // named as the CPU solver's SaveArrays names them.
  virtual void DownloadCheckpointArrays(ParticleArrays& particles,
                                        std::vector<SolverArray>& solver_arrays) const = 0;
  // Positions, velocities (xyz triples) and densities in particle-id order; null: not copied.
  virtual void DownloadById(float* position, float* velocity, float* density) const = 0;
  // The particles of BelowRank(id, threshold) (threshold > 0; dysa/detail_rank.h) in id order:
  // chosen and packed on the device, so only they cross to the host (cuda/rank_subset.cuh).
  virtual RankSubsetCopy DownloadBelowRank(uint32_t threshold, bool position, bool velocity,
                                           bool density) const = 0;
  // The probes' gather (probe_gather.h) over the device's particles, on the device.
  virtual void GatherProbes(const ProbeGatherPlan& plan, ProbeGather& out) const = 0;

  struct StepReport {
    std::vector<double> pass_ms;  // per pass, from CUDA events
    bool finite = true;           // every position and velocity finite afterwards
    uint64_t limited = 0;         // particles slowed by the velocity limiter
    // The most particles one grid cell held at the step's neighbour sort. Beyond
    // NeighborGrid::kMaxParticlesPerCell the physical solvers stop the step after the sort and
    // its first neighbour pass, before they integrate (stopped); the seed's step completes.
    uint32_t max_cell_count = 0;
    bool stopped = false;  // the step stopped before it changed the particles' motion
  };
  // One step of state.dt (set by the caller for a fixed-step solver).
  virtual StepReport Step(const Model& model, State& state) = 0;
  // Device memory held, bytes.
  virtual uint64_t DeviceBytes() const = 0;
  // The latest step's solver diagnostics.
  virtual SolverStats stats() const { return {}; }

 protected:
  DeviceInfo info_;
};

// The GPU backend of `solver` on `device`. Throws ConfigError("device", ...) when the device
// cannot run (naming what is missing) or the solver has no GPU backend.
std::unique_ptr<GpuBackend> CreateGpuBackend(const Device& device, std::string_view solver);

// The solvers with a GPU backend in this build (none without DYSA_CUDA).
std::vector<std::string> GpuSolvers();

}  // namespace dysa
