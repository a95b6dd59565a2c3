#include "server_ranks.h"

#include <omp.h>

#include <exception>

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

}  // namespace

struct ServerRanks::Parts {
  Parts(int* argc, char*** argv, double balance_threshold, double rank_timeout)
      : session(argc, argv, /*any_thread=*/true),
        comm({.wait_limit_s = rank_timeout}),
        runner(std::make_shared<distributed::RankRunner>(comm, Balance(balance_threshold))) {}
  distributed::MpiSession session;
  distributed::MpiCommunicator comm;
  std::shared_ptr<distributed::RankRunner> runner;
};

ServerRanks::ServerRanks(int* argc, char*** argv, double balance_threshold, double rank_timeout)
    : parts_(std::make_unique<Parts>(argc, argv, balance_threshold, rank_timeout)) {}

ServerRanks::~ServerRanks() {
  if (rank() != 0) return;
  try {
    parts_->runner->Send(distributed::StopCommand());
  } catch (const std::exception&) {
    parts_->comm.Abort(1);
  }
}

int ServerRanks::rank() const { return parts_->comm.rank(); }
int ServerRanks::size() const { return parts_->comm.size(); }

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
