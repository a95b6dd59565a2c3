#include "dysa/distributed/ghost_refresh.h"

#include <cstring>
#include <stdexcept>
#include <string>

namespace dysa::distributed {
namespace {

// Packs values[index[0]], values[index[1]], ... as raw bytes (a Vec3 is its 3 Reals).
static_assert(sizeof(Vec3) == 3 * sizeof(Real));
template <class T>
Bytes Pack(std::span<const T> values, const std::vector<uint32_t>& index) {
  Bytes out(index.size() * sizeof(T));
  for (size_t k = 0; k < index.size(); ++k) {
    std::memcpy(out.data() + k * sizeof(T), &values[index[k]], sizeof(T));
  }
  return out;
}

}  // namespace

void GhostRefresh::Plan(const Communicator& comm, const Slabs& slabs, std::span<const int> layer,
                        std::span<const uint8_t> ghost, std::span<const uint32_t> id) {
  const size_t processes = size_t(comm.size());
  send_.assign(processes, {});
  receive_.assign(processes, {});
  for (size_t k = 0; k < layer.size(); ++k) {
    if (ghost[k] == 0) {
      for (int reader : slabs.GhostReaders(layer[k])) send_[size_t(reader)].push_back(uint32_t(k));
    } else {
      receive_[size_t(slabs.OwnerOf(layer[k]))].push_back(uint32_t(k));
    }
  }
  // The check of the order argument above: the ids sent are the ghosts' ids, in order.
  std::vector<Bytes> to(processes);
  for (size_t q = 0; q < processes; ++q) to[q] = Pack<uint32_t>(id, send_[q]);
  const std::vector<Bytes> from = comm.AllToAll(to);
  for (size_t p = 0; p < processes; ++p) {
    if (int(p) == comm.rank()) continue;
    const Bytes expected = Pack<uint32_t>(id, receive_[p]);
    if (from[p] != expected) {
      throw std::logic_error("GhostRefresh: process " + std::to_string(p) + " sends " +
                             std::to_string(from[p].size() / sizeof(uint32_t)) +
                             " particles that do not match, in order, the " +
                             std::to_string(receive_[p].size()) + " ghosts of process " +
                             std::to_string(comm.rank()) + " it owns");
    }
  }
}

uint64_t GhostRefresh::Refresh(const Communicator& comm, std::span<Vec3> values) const {
  const size_t processes = size_t(comm.size());
  std::vector<Bytes> to(processes);
  uint64_t bytes = 0;
  for (size_t q = 0; q < processes; ++q) {
    to[q] = Pack<Vec3>(values, send_[q]);
    bytes += to[q].size();
  }
  const std::vector<Bytes> from = comm.AllToAll(to);
  for (size_t p = 0; p < processes; ++p) {
    if (int(p) == comm.rank()) continue;
    const std::vector<uint32_t>& index = receive_[p];
    if (from[p].size() != index.size() * sizeof(Vec3)) {
      throw std::logic_error("GhostRefresh: process " + std::to_string(p) + " sent " +
                             std::to_string(from[p].size()) + " bytes for " +
                             std::to_string(index.size()) + " ghosts");
    }
    for (size_t k = 0; k < index.size(); ++k) {
      std::memcpy(values[index[k]].data(), from[p].data() + k * sizeof(Vec3), sizeof(Vec3));
    }
  }
  return bytes;
}

}  // namespace dysa::distributed
