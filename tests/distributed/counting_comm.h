// A Communicator that passes every operation on to another and counts what this process sent:
// the tests' measure of what a gather moved (the view reads on ranks send each rank's share only).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "dysa/distributed/communicator.h"

namespace dysa::distributed {

class CountingComm final : public Communicator {
 public:
  explicit CountingComm(const Communicator& inner) : inner_(inner) {}

  int rank() const override { return inner_.rank(); }
  int size() const override { return inner_.size(); }
  void MaxInPlace(std::span<double> values) const override {
    max_values += values.size();
    inner_.MaxInPlace(values);
  }
  void SumInPlace(std::span<int64_t> values) const override {
    sum_values += values.size();
    inner_.SumInPlace(values);
  }
  std::vector<Bytes> AllToAll(const std::vector<Bytes>& to) const override {
    for (const Bytes& b : to) all_to_all_bytes += b.size();
    return inner_.AllToAll(to);
  }
  std::vector<Bytes> GatherToRoot(std::span<const std::byte> mine) const override {
    gathered.push_back(mine.size());
    return inner_.GatherToRoot(mine);
  }
  void Broadcast(Bytes& bytes) const override {
    if (inner_.rank() == 0) broadcast_bytes += bytes.size();
    inner_.Broadcast(bytes);
  }

  void Clear() const {
    max_values = sum_values = all_to_all_bytes = broadcast_bytes = 0;
    gathered.clear();
  }
  uint64_t GatheredBytes() const {
    uint64_t sum = 0;
    for (const size_t b : gathered) sum += b;
    return sum;
  }

  // Since the latest Clear: values in maxima and sums, bytes sent to all processes (itself
  // included), each gather's bytes sent by this process, bytes broadcast by process 0.
  mutable uint64_t max_values = 0, sum_values = 0, all_to_all_bytes = 0, broadcast_bytes = 0;
  mutable std::vector<size_t> gathered;

 private:
  const Communicator& inner_;
};

}  // namespace dysa::distributed
