// MPI_COMM_WORLD as a Communicator. This header does not include mpi.h: only
// mpi_communicator.cc sees MPI, so nothing above this library needs MPI's headers.
#pragma once

#include <cstddef>
#include <cstdint>

#include "dysa/distributed/communicator.h"

namespace dysa::distributed {

// MPI_Init on construction, MPI_Finalize on destruction: one per process, for its lifetime.
class MpiSession {
 public:
  // Only the main thread calls MPI; with `any_thread`, any one thread at a time may
  // (MPI_THREAD_SERIALIZED: the server's simulation thread), or the constructor throws.
  MpiSession(int* argc, char*** argv, bool any_thread = false);
  ~MpiSession();
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;
};

// True when this process was started by mpirun/mpiexec (Open MPI's or a PMIx launcher's
// environment), so that a plain `dysa run` never initialises MPI.
bool LaunchedByMpirun();

// Messages of any size: MPI's counts and offsets are int and Open MPI 4.1 has no large-count
// calls, so AllToAll, GatherToRoot and Broadcast move their bytes in rounds of at most
// `round_bytes` per message (and at most 2^31 - 1 in a round's buffer of one chunk per
// process). The sizes travel as 64-bit integers first; every process then takes part in the
// rounds the longest message needs.
//
// A rank that hangs (stopped, deadlocked, its node gone without a signal) would leave the others
// in a collective forever: every collective is started non-blocking and polled, and one that
// has not completed after `wait_limit_s` ends the job (MPI_Abort, exit status 3) with a line on
// stderr that names the rank and the call. The exception is Broadcast's wait for the size of
// process 0's next message: the server's other ranks wait there between commands, for as long
// as the server is paused.
class MpiCommunicator final : public Communicator {
 public:
  static constexpr size_t kDefaultRoundBytes = size_t(1) << 30;
  static constexpr double kDefaultWaitLimit = 30;  // s; --rank-timeout

  struct Options {
    size_t round_bytes = kDefaultRoundBytes;  // >= 1 (tests use a few bytes)
    double wait_limit_s = kDefaultWaitLimit;  // > 0, s
  };

  // MPI_COMM_WORLD; needs a live MpiSession. Throws std::invalid_argument on options out of
  // range.
  MpiCommunicator() : MpiCommunicator(Options{}) {}
  explicit MpiCommunicator(const Options& options);
  int rank() const override { return rank_; }
  int size() const override { return size_; }
  void MaxInPlace(std::span<double> values) const override;
  void SumInPlace(std::span<int64_t> values) const override;
  std::vector<Bytes> AllToAll(const std::vector<Bytes>& to) const override;
  std::vector<Bytes> GatherToRoot(std::span<const std::byte> mine) const override;
  // The size travels first in a non-blocking broadcast that a waiting process polls, sleeping
  // between polls once a millisecond has passed (without limit but on process 0); then the
  // bytes.
  void Broadcast(Bytes& bytes) const override;
  // The bytes a round moves per message.
  size_t round_bytes() const { return round_; }
  double wait_limit_s() const { return wait_limit_s_; }
  // Ends every process of the job (a rank that fails alone would leave the others waiting in
  // a collective forever).
  [[noreturn]] void Abort(int code) const;

 private:
  uint64_t MaxOverProcesses(uint64_t value) const;

  int rank_ = 0;
  int size_ = 1;
  size_t round_ = kDefaultRoundBytes;
  double wait_limit_s_ = kDefaultWaitLimit;
};

}  // namespace dysa::distributed
