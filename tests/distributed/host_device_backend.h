// A stand-in for a GPU's StepBackend on the host, to test the ranks' device step
// (server/distributed/src/distributed_device_step.cc) where there is no GPU: it steps what it
// was uploaded with the CPU solver's passes, every particle computing everything as on a device,
// the ghosts (particles sorted into cell layers the process does not own,
// ProcessShare::owned_layers) left out of the CFL maxima only, and reads back the cells of its
// sorts as the CUDA backends do.
//
// dfsph (ProcessShare::device_ghosts set): as the GPU's backend (dfsph_gpu_backend.cc), after
// the sort it hands the driver each particle's id and cell and takes the plan back, whose ghost
// flags keep the ghosts out of the solves' mean errors, the maxima and the speed limiter's
// count (summed and maximised over the processes through ProcessShare, as the CPU's passes do);
// and every refresh of the ghosts' velocities goes through the hook as on the device: only the
// plan's `sent` particles are read, the hook exchanges them, only its `received` ghosts are
// written.
#pragma once

#include <algorithm>
#include <cstdint>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "dysa/core/device_ghost_exchange.h"
#include "dysa/core/solver.h"
#include "dysa/core/state.h"
#include "dysa/core/step_backend.h"

namespace dysa::testing {

class HostDeviceBackend final : public StepBackend {
 public:
  explicit HostDeviceBackend(const std::string& solver) : solver_(FindSolver(solver).create()) {}

  std::string Describe(const Device&) const override { return "host stand-in for a GPU"; }
  std::vector<std::string> Configure(const Model& model) override {
    passes_ = solver_->BuildPasses(model);
    std::vector<std::string> names;
    for (const Pass& pass : passes_) names.push_back(pass.name);
    return names;
  }
  void Upload(const ParticleArrays& particles,
              std::span<const SolverArray> solver_arrays) override {
    state_.particles = particles;
    solver_->RestoreArrays(solver_arrays, particles.size());
  }
  void Download(ParticleArrays& particles) const override { particles = state_.particles; }
  void DownloadCheckpointArrays(ParticleArrays& particles,
                                std::vector<SolverArray>& solver_arrays) const override {
    particles = state_.particles;
    solver_arrays = solver_->SaveArrays();
  }
  void DownloadById(float*, float*, float*) const override {
    throw std::logic_error("not read on ranks");
  }
  bool gathers_probes() const override { return false; }
  void GatherProbes(const ProbeGatherPlan&, ProbeGather&) const override {
    throw std::logic_error("not read on ranks");
  }
  uint64_t DeviceBytes() const override { return 0; }
  bool DownloadSortedCells(std::vector<uint32_t>& cells) const override {
    cells = Cells();
    return true;
  }
  bool DownloadSolverArrays(std::vector<SolverArray>& solver_arrays) const override {
    solver_arrays = solver_->SaveArrays();
    return true;
  }
  bool DownloadFirstSortCells(std::vector<uint32_t>& ids,
                              std::vector<uint32_t>& cells) const override {
    ids = first_ids_;
    cells = first_cells_;
    return first_kept_;
  }

  StepReport Step(const Model& model, State& outer) override {
    State& s = state_;
    s.time = outer.time;
    s.step = outer.step;
    s.dt = outer.dt;
    s.max_dt = outer.max_dt;
    s.warning.clear();
    s.share = {};
    s.share.max_over_processes = outer.share.max_over_processes;
    s.share.sum_over_processes = outer.share.sum_over_processes;
    s.share.rate_reach = 255;  // every ghost computes its rates, as on a device
    first_kept_ = false;
    const std::vector<uint8_t>& owned = outer.share.owned_layers;
    DeviceGhostExchange* exchange = outer.share.device_ghosts;
    if (exchange) {
      s.share.refresh_ghosts = [this, exchange](std::span<Vec3> values) {
        sent_.resize(plan_.sent.size());
        for (size_t k = 0; k < sent_.size(); ++k) sent_[k] = values[plan_.sent[k]];
        received_.resize(plan_.received.size());
        exchange->Exchange(sent_, received_);
        for (size_t k = 0; k < received_.size(); ++k) values[plan_.received[k]] = received_[k];
      };
    }
    const std::string corrector = std::string(kNeighbourSortPass) + "_corrector";
    StepReport report;
    for (const Pass& pass : passes_) {
      pass.run(model, s);
      report.pass_ms.push_back(0);
      const bool second = pass.name == corrector;
      if (pass.name != kNeighbourSortPass && !second) continue;
      report.max_cell_count = std::max(report.max_cell_count, s.grid.max_cell_count());
      if (owned.empty()) continue;
      if (exchange) {  // dfsph: the flags and the refresh's pattern from the driver's plan
        plan_ = exchange->PlanAfterSort(s.particles.id, Cells());
        s.share.ghost = plan_.ghost;
        continue;
      }
      // The predictor-corrector's first sort, kept for the driver's check of the half step.
      if (!second && model.params.time_integration == 1) {
        first_ids_ = s.particles.id;
        first_cells_ = Cells();
        first_kept_ = true;
      }
      s.share.ghost.assign(s.particles.size(), 0);
      for (size_t k = 0; k < s.particles.size(); ++k) {
        s.share.ghost[k] =
            owned[size_t(s.grid.SortedCell(uint32_t(k))[outer.share.layer_axis])] ? 0 : 1;
      }
    }
    outer.dt = s.dt;
    outer.warning = s.warning;
    return report;
  }

 private:
  std::vector<uint32_t> Cells() const {
    std::vector<uint32_t> cells(state_.particles.size());
    for (size_t k = 0; k < cells.size(); ++k) {
      cells[k] = state_.grid.CellIndex(state_.grid.SortedCell(uint32_t(k)));
    }
    return cells;
  }

  std::unique_ptr<Solver> solver_;
  std::vector<Pass> passes_;
  State state_;
  bool first_kept_ = false;
  std::vector<uint32_t> first_ids_, first_cells_;
  DeviceGhostExchange::Plan plan_;  // dfsph's, of the latest sort
  std::vector<Vec3> sent_, received_;
};

}  // namespace dysa::testing
