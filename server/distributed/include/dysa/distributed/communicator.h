// The collective operations a simulation spread over processes needs, behind an interface so
// that the decomposition builds and runs without MPI: on one process (SingleProcess) every
// operation is the identity, and with MPI (server/distributed/mpi) they are MPI collectives.
// Every method is collective: all processes call it, in the same order.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace dysa::distributed {

using Bytes = std::vector<std::byte>;

class Communicator {
 public:
  virtual ~Communicator() = default;
  virtual int rank() const = 0;
  virtual int size() const = 0;
  // Each value becomes its maximum over the processes (exact in any order).
  virtual void MaxInPlace(std::span<double> values) const = 0;
  // Each value becomes its sum over the processes (integers: exact in any order).
  virtual void SumInPlace(std::span<int64_t> values) const = 0;
  // to[p] goes to process p (size() buffers); returns what each process sent to this one.
  virtual std::vector<Bytes> AllToAll(const std::vector<Bytes>& to) const = 0;
  // Process 0 gets every process's `mine`, by rank; the others get nothing.
  virtual std::vector<Bytes> GatherToRoot(std::span<const std::byte> mine) const = 0;
  // Process 0's `bytes` become every process's (any size). The others may wait here long (the
  // server's ranks between commands), so they wait without spinning a core.
  virtual void Broadcast(Bytes& bytes) const = 0;
};

// The group of this process alone.
class SingleProcess final : public Communicator {
 public:
  int rank() const override { return 0; }
  int size() const override { return 1; }
  void MaxInPlace(std::span<double>) const override {}
  void SumInPlace(std::span<int64_t>) const override {}
  std::vector<Bytes> AllToAll(const std::vector<Bytes>& to) const override { return to; }
  std::vector<Bytes> GatherToRoot(std::span<const std::byte> mine) const override {
    return {Bytes(mine.begin(), mine.end())};
  }
  void Broadcast(Bytes&) const override {}
};

}  // namespace dysa::distributed
