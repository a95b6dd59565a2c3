// The server's simulation on ranks (docs/distributed.md): process 0's dysa::Simulation steps on
// the ranks' backend (ranks_backend.h), which turns each thing it needs of the particles (a
// scene, parameters, new particles, a step, a gather) into one small command, broadcasts it,
// and then performs it like every other process: RankRunner::Run on each process, so that all
// take part in the same collectives in the same order. The other processes wait for the next
// command (ServeRanks) until process 0 sends Stop.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "dysa/core/params.h"
#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "dysa/core/solver.h"
#include "dysa/core/state.h"
#include "dysa/core/step_backend.h"
#include "dysa/core/view_selection.h"
#include "dysa/distributed/communicator.h"
#include "dysa/distributed/distributed_simulation.h"

namespace dysa::distributed {

// The commands, encoded (rank_runner.cc has their layout).
Bytes SceneCommand(const Scene& scene);  // a new DistributedSimulation of this scene
Bytes ConfigureCommand(const Params& params);
// The particles (and solver arrays) that replace every process's: each keeps its slab.
Bytes UploadCommand(const ParticleArrays& particles, std::span<const SolverArray> arrays);
Bytes StepCommand(double time, uint64_t step, double max_dt);
// Every particle on process 0, in one process's storage order; with a threshold > 0, only those
// of BelowRank(id, threshold).
Bytes GatherCommand(uint32_t threshold = 0);
Bytes CheckpointCommand();  // a checkpoint on process 0
// A view stream's reads (DistributedSimulation::GatherParticlesByIds, PositionBounds,
// SelectViewSubset): `fields` are ReadFields bits. The subset's weigher is process 0's, passed
// to Send.
Bytes ReadIdsCommand(std::span<const uint32_t> ids, uint32_t fields);
Bytes PositionBoundsCommand();
Bytes ViewSubsetCommand(const ViewSubsetRequest& request, uint64_t budget, uint32_t fields);
Bytes StopCommand();

// What a command gave on process 0 (empty elsewhere).
struct RankResult {
  DistributedSimulation::StepOutcome outcome;  // a step's
  ParticleArrays particles;                    // a gather's, a read by ids', a view subset's
  std::vector<uint32_t> ids;                   // a view subset's, increasing
  Simulation::PositionBounds bounds;           // PositionBoundsCommand's
  Checkpoint checkpoint;                       // a checkpoint's
  bool stop = false;                           // Stop: the processes are done
};

class RankRunner {
 public:
  // Builds a stand-in for a GPU's step backend for a solver (tests: host_device_backend.h).
  using DeviceStandIn = std::function<std::unique_ptr<StepBackend>(const std::string& solver)>;

  // `comm` must outlive this. Each scene's simulation re-balances with `balance` and steps on
  // this process's entry of `devices` (every process's device by rank, DevicesOfRanks: GPU
  // ranks, distributed_device_step.cc); empty: every process on the CPU.
  explicit RankRunner(const Communicator& comm, BalanceSettings balance = {},
                      std::vector<Device> devices = {})
      : comm_(comm), balance_(balance), devices_(std::move(devices)) {}

  const Communicator& comm() const { return comm_; }
  // This process's device (the CPU without `devices`) and every process's, by rank.
  Device device() const { return devices_.empty() ? Device{} : devices_[size_t(comm_.rank())]; }
  const std::vector<Device>& devices() const { return devices_; }
  // Tests: on GPU ranks each scene's simulation steps on `stand_in`'s backend instead of the
  // GPU's (the device path of the step without a GPU). What runs is still checked against
  // device() (CheckRunsOnRanks).
  void set_device_stand_in(DeviceStandIn stand_in) { stand_in_ = std::move(stand_in); }
  // The simulation of the latest scene; null before the first.
  const DistributedSimulation* simulation() const { return sim_.get(); }

  // Process 0: broadcasts `command` and performs it. A ConfigError (a scene or parameters that
  // cannot run across processes) is thrown on every process alike, nothing applied. `weigh`:
  // a ViewSubsetCommand's weigher (process 0 alone calls it).
  RankResult Send(Bytes command, const ViewWeigher* weigh = nullptr);
  // The other processes: receives and performs one command; false once it was Stop. A
  // ConfigError is process 0's to report: here it is skipped (nothing applied here either),
  // except one naming "device": a GPU that failed on this process alone (process 0 checked
  // what runs), which throws std::runtime_error so that the job ends instead of waiting.
  bool ServeOne();

 private:
  RankResult Run(const Bytes& command, const ViewWeigher* weigh = nullptr);

  const Communicator& comm_;
  const BalanceSettings balance_;
  const std::vector<Device> devices_;
  DeviceStandIn stand_in_;
  std::unique_ptr<DistributedSimulation> sim_;
};

// The other processes' loop: serves commands until Stop. Exceptions other than ConfigError
// propagate (the caller aborts the job: process 0 would wait for this one forever).
void ServeRanks(RankRunner& runner);

}  // namespace dysa::distributed
