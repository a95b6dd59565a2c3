// dysa-server under mpirun (docs/distributed.md): one simulation over the ranks, rank 0 serving
// gRPC. Rank 0's simulation thread steps its Simulation on the ranks' backend
// (ranks_backend.h), which sends every other rank each step, gather and change as one
// broadcast command; the other ranks serve those commands until rank 0 stops them. Built with
// DYSA_MPI only (server_main.cc's DYSA_WITH_MPI).
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "dysa/core/device.h"
#include "dysa/core/simulation.h"

namespace dysa::service {

class ServerRanks {
 public:
  // Initialises MPI (any one thread at a time: rank 0's simulation thread steps). Throws
  // std::runtime_error when MPI cannot. The ranks move their slab cuts when the max/mean of
  // their step times over a window exceeds `balance_threshold` (balancer.h). A rank that waits
  // longer than `rank_timeout` seconds in one collective (another rank hangs) ends the job
  // (MpiCommunicator). `device`: the --device text; with a CUDA device each rank steps on its
  // GPU (DeviceOfRank: "cuda" by local rank, "cuda:N" all on N). When any rank cannot use its
  // GPU every rank learns it before anything else is collective (device_error).
  ServerRanks(int* argc, char*** argv, double balance_threshold, double rank_timeout,
              const std::string& device = "cpu");
  // Rank 0: tells the other ranks to stop, so that they end with it; then finalises MPI.
  ~ServerRanks();
  ServerRanks(const ServerRanks&) = delete;
  ServerRanks& operator=(const ServerRanks&) = delete;

  int rank() const;
  int size() const;
  // This rank's device (HostOptions::device on rank 0).
  Device device() const;
  // Empty, or why some rank cannot use its GPU (the same on every rank: none may serve or step;
  // each exits 2, rank 0 saying why).
  const std::string& device_error() const;
  // Rank 0: the backend factory for HostOptions::backend.
  Simulation::BackendFactory backend() const;
  // The other ranks: serves rank 0's commands with `threads` OpenMP threads (0: the default)
  // until it stops them; returns the exit status. An error here ends the whole job
  // (MPI_Abort): rank 0 would otherwise wait for this rank forever.
  int Serve(int threads, const std::function<void(const std::string&)>& log);

 private:
  struct Parts;
  std::unique_ptr<Parts> parts_;
};

// True when mpirun started this process.
bool LaunchedByMpirun();

}  // namespace dysa::service
