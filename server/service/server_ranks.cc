#include "server_ranks.h"

#include <omp.h>

#include <exception>
#include <string>
#include <vector>

#include "dysa/distributed/rank_device.h"
#include "dysa/distributed/rank_runner.h"
#include "dysa/distributed/ranks_backend.h"
#include "mpi_communicator.h"

namespace dysa::service {

namespace {

distributed::BalanceSettings Balance(double threshold) {
  distributed::BalanceSettings settings;
  settings.threshold = threshold;
  return settings;
}

// Every rank's device, learnt right after MPI starts: a rank that cannot use its GPU (another
// host may lack the driver, an ordinal past its GPUs) refuses on every rank alike, as `dysa run`
// under mpirun does (CheckRankDevicesUsable), before the first scene's collectives. `error`:
// why not (then no devices).
std::vector<Device> RankDevices(const distributed::Communicator& comm, const std::string& text,
                                std::string& error) {
  try {
    const Device mine =
        distributed::DeviceOfRank(text, distributed::LocalRank(), CudaDeviceCount());
    if (!mine.is_cuda()) return {};
    distributed::CheckRankDevicesUsable(comm, mine);
    return distributed::DevicesOfRanks(comm, mine);
  } catch (const ConfigError& e) {
    error = e.message();
    return {};
  }
}

}  // namespace

struct ServerRanks::Parts {
  Parts(int* argc, char*** argv, double balance_threshold, double rank_timeout,
        const std::string& device)
      : session(argc, argv, /*any_thread=*/true),
        comm({.wait_limit_s = rank_timeout}),
        runner(std::make_shared<distributed::RankRunner>(
            comm, Balance(balance_threshold), RankDevices(comm, device, device_error))) {}
  distributed::MpiSession session;
  distributed::MpiCommunicator comm;
  std::string device_error;  // before runner: RankDevices writes it
  std::shared_ptr<distributed::RankRunner> runner;
};

ServerRanks::ServerRanks(int* argc, char*** argv, double balance_threshold, double rank_timeout,
                         const std::string& device)
    : parts_(std::make_unique<Parts>(argc, argv, balance_threshold, rank_timeout, device)) {}

ServerRanks::~ServerRanks() {
  // Without usable GPUs no rank serves: there is no one to stop.
  if (rank() != 0 || !parts_->device_error.empty()) return;
  try {
    parts_->runner->Send(distributed::StopCommand());
  } catch (const std::exception&) {
    parts_->comm.Abort(1);
  }
}

int ServerRanks::rank() const { return parts_->comm.rank(); }
int ServerRanks::size() const { return parts_->comm.size(); }
Device ServerRanks::device() const { return parts_->runner->device(); }
const std::string& ServerRanks::device_error() const { return parts_->device_error; }

Simulation::BackendFactory ServerRanks::backend() const {
  return distributed::RanksBackendFactory(parts_->runner);
}

int ServerRanks::Serve(int threads, const std::function<void(const std::string&)>& log) {
  if (threads > 0) omp_set_num_threads(threads);
  try {
    distributed::ServeRanks(*parts_->runner);
  } catch (const std::exception& e) {
    log("error on rank " + std::to_string(rank()) + ": " + e.what() + "; ending every rank");
    parts_->comm.Abort(1);
  }
  return 0;
}

bool LaunchedByMpirun() { return distributed::LaunchedByMpirun(); }

}  // namespace dysa::service
