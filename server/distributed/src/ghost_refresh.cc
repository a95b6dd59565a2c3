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
  std::vector<Vec3> sent, received;
  for (const std::vector<uint32_t>& index : send_) {
    for (uint32_t k : index) sent.push_back(values[k]);
  }
  for (const std::vector<uint32_t>& index : receive_)
    received.resize(received.size() + index.size());
  const uint64_t bytes = Exchange(comm, sent, received);
  size_t at = 0;
  for (const std::vector<uint32_t>& index : receive_) {
    for (uint32_t k : index) values[k] = received[at++];
  }
  return bytes;
}

std::vector<uint32_t> GhostRefresh::Sent() const {
  std::vector<uint32_t> all;
  for (const std::vector<uint32_t>& index : send_)
    all.insert(all.end(), index.begin(), index.end());
  return all;
}

std::vector<uint32_t> GhostRefresh::Received() const {
  std::vector<uint32_t> all;
  for (const std::vector<uint32_t>& index : receive_) {
    all.insert(all.end(), index.begin(), index.end());
  }
  return all;
}

uint64_t GhostRefresh::Exchange(const Communicator& comm, std::span<const Vec3> sent,
                                std::span<Vec3> received) const {
  const size_t processes = size_t(comm.size());
  std::vector<Bytes> to(processes);
  uint64_t bytes = 0;
  size_t at = 0;
  for (size_t q = 0; q < processes; ++q) {
    const size_t count = send_[q].size();
    if (at + count > sent.size()) throw std::logic_error("GhostRefresh: too few values to send");
    to[q].resize(count * sizeof(Vec3));
    if (count > 0) std::memcpy(to[q].data(), sent[at].data(), count * sizeof(Vec3));
    at += count;
    bytes += to[q].size();
  }
  const std::vector<Bytes> from = comm.AllToAll(to);
  at = 0;
  for (size_t p = 0; p < processes; ++p) {
    // No process holds ghosts of its own particles (Slabs::GhostReaders excludes the owner).
    const size_t count = receive_[p].size();
    if (from[p].size() != count * sizeof(Vec3) || at + count > received.size()) {
      throw std::logic_error("GhostRefresh: process " + std::to_string(p) + " sent " +
                             std::to_string(from[p].size()) + " bytes for " +
                             std::to_string(count) + " ghosts");
    }
    if (count > 0) std::memcpy(received[at].data(), from[p].data(), count * sizeof(Vec3));
    at += count;
  }
  return bytes;
}

}  // namespace dysa::distributed
