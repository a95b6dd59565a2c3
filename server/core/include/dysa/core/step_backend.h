// Where a Simulation's steps run when not in its own CPU passes, behind the narrow interface
// Simulation uses: the particles live elsewhere between steps (GPU memory, or the slabs of
// several processes) and cross to this process's host arrays only when read (frames,
// checkpoints, probes, status) or replaced (reset, restore). The GPU's backends implement it
// in core (gpu_backend.h); the ranks' one in server/distributed (ranks_backend.h).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "dysa/core/device.h"
#include "dysa/core/model.h"
#include "dysa/core/params.h"
#include "dysa/core/solver.h"
#include "dysa/core/state.h"

namespace dysa {

struct ProbeGatherPlan;
struct ProbeGather;
struct ViewSubsetRequest;  // dysa/core/view_selection.h

class StepBackend {
 public:
  virtual ~StepBackend() = default;

  // "cuda:0 NVIDIA H200, ...", "cpu, 3 ranks": Simulation::DeviceDescription.
  virtual std::string Describe(const Device& device) const = 0;
  // Throws ConfigError, naming the field, for parameters this backend cannot run with, before
  // Simulation applies any of them (the ranks run only some solvers). Accepts all by default.
  virtual void CheckParams(const Params&) const {}

  // Sets up the passes of `model` (rebuilt whenever parameters change) and returns their
  // names, the CPU solver's.
  virtual std::vector<std::string> Configure(const Model& model) = 0;
  // Replaces the backend's particles with `particles` (ids, positions, velocities) and the
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
  // As DownloadById, only for the particles of BelowRank(id, threshold) (threshold > 0;
  // dysa/detail_rank.h), chosen where they live so that only they cross; the other entries are
  // left as they are. Returns how many were copied, or nothing where this backend has no such
  // read (Simulation then reads every particle).
  virtual std::optional<size_t> DownloadByIdBelowRank(uint32_t /*threshold*/, float* /*position*/,
                                                      float* /*velocity*/,
                                                      float* /*density*/) const {
    return std::nullopt;
  }
  // The reads of a view stream (Simulation::ReadParticlesByIds, ReadPositionBounds,
  // ReadViewSubset), done where the particles live so that only what the view sends crosses.
  // Each returns nothing (false) where this backend has no such read: Simulation then reads
  // every particle and chooses on the host, as before.
  //
  // The particles `ids` (each below the particle count): their asked arrays (null: not copied)
  // at their ids' entries; the other entries are left as they are. Returns ids.size().
  virtual std::optional<size_t> GatherByIds(std::span<const uint32_t> /*ids*/, float* /*position*/,
                                            float* /*velocity*/, float* /*density*/) const {
    return std::nullopt;
  }
  // Per axis every particle's smallest and largest position as Simulation::ReadPositionBounds
  // gives them (a NaN skipped, a zero extreme signed as the first zero in storage order; +inf
  // and -inf without particles).
  virtual bool ReducePositionBounds(std::array<float, 3>& /*lo*/,
                                    std::array<float, 3>& /*hi*/) const {
    return false;
  }
  // The ids ViewKeys(every particle, request).Select(budget) chooses, into `ids` (increasing),
  // and their asked arrays at their ids' entries. Returns ids.size().
  virtual std::optional<size_t> SelectViewSubset(const ViewSubsetRequest& /*request*/,
                                                 uint64_t /*budget*/,
                                                 std::vector<uint32_t>& /*ids*/,
                                                 float* /*position*/, float* /*velocity*/,
                                                 float* /*density*/) const {
    return std::nullopt;
  }
  // Whether GatherProbes runs where the particles are; otherwise Simulation downloads them and
  // gathers on the host.
  virtual bool gathers_probes() const { return true; }
  // The probes' gather (probe_gather.h) over the backend's particles (gathers_probes()).
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
    // Non-empty: the backend stopped the step itself, before it changed the particles' motion,
    // and says why (the ranks: a particle without an owner, a crowded cell). Simulation raises
    // it as its alarm.
    std::string alarm{};
  };
  // One step of state.dt (set by the caller for a fixed-step solver); a physical solver's step
  // is capped at state.max_dt and sets state.dt. state.time and state.step are those before the
  // step (the caller advances them).
  virtual StepReport Step(const Model& model, State& state) = 0;
  // Device memory held, bytes.
  virtual uint64_t DeviceBytes() const = 0;
  // For a driver that steps one process's owned particles and ghosts here (the ranks' device
  // step, server/distributed): the cell (NeighborGrid::CellIndex) each particle was sorted into
  // at the latest step's neighbour sort, storage order, into `cells` (resized); false where
  // this backend does not keep them.
  virtual bool DownloadSortedCells(std::vector<uint32_t>& /*cells*/) const { return false; }
  // The same for the first of a step's two sorts (wcsph's predictor-corrector, by the positions
  // at t; DownloadSortedCells has the second's, at t + dt/2), with each particle's id, in that
  // sort's order; kept only on one of several processes (ProcessShare::owned_layers set). False
  // where the latest step did not keep them.
  virtual bool DownloadFirstSortCells(std::vector<uint32_t>& /*ids*/,
                                      std::vector<uint32_t>& /*cells*/) const {
    return false;
  }
  // The driver uploads and downloads every step (the ranks' device step): copies go through
  // page-locked host buffers kept between steps. Nothing to do where there is no device.
  virtual void StageThroughPinnedMemory() {}
  // The solver's carried arrays only, named as Solver::SaveArrays names them (those of
  // DownloadCheckpointArrays); false where this backend does not read them alone.
  virtual bool DownloadSolverArrays(std::vector<SolverArray>& /*solver_arrays*/) const {
    return false;
  }
  // The latest step's solver diagnostics.
  virtual SolverStats stats() const { return {}; }
};

// The backend `Simulation` steps `solver` with on CUDA `device` (gpu_backend.h), for a driver
// outside core: the ranks' device step (server/distributed). Throws ConfigError("device", ...)
// when the device cannot run or the solver has no GPU backend.
std::unique_ptr<StepBackend> CreateDeviceStepBackend(const Device& device, std::string_view solver);

}  // namespace dysa
