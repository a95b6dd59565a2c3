// DistributedSimulation's reads for a view stream (a camera): the particles of given ids, every
// particle's position bounds and a view's subset, each gathered to process 0 as its part only:
// every process chooses among its own particles (owned ones: between steps a process holds no
// ghosts), so what crosses scales with what the view sends, not with the simulation. The results
// are, bit for bit, one process's (Simulation::ReadParticlesByIds, ReadPositionBounds,
// ReadViewSubset): the values are copies, and the selections are exact (min, max, integer
// counts, and keys computed per particle by the one definition in dysa/view_key.h).
#include <algorithm>
#include <array>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "dysa/distributed/distributed_simulation.h"
#include "dysa/view_key.h"

namespace dysa::distributed {
namespace {

// One particle's record: its id, then the asked arrays (position, velocity, density).
size_t RecordSize(uint32_t fields) {
  return sizeof(uint32_t) + ((fields & kReadPosition) ? 3 * sizeof(Real) : 0) +
         ((fields & kReadVelocity) ? 3 * sizeof(Real) : 0) +
         ((fields & kReadDensity) ? sizeof(Real) : 0);
}

void PutRecord(const ParticleArrays& p, size_t i, uint32_t fields, Bytes& out) {
  const size_t at = out.size();
  out.resize(at + RecordSize(fields));
  std::byte* to = out.data() + at;
  std::memcpy(to, &p.id[i], sizeof(uint32_t));
  to += sizeof(uint32_t);
  if (fields & kReadPosition) {
    std::memcpy(to, p.position[i].data(), 3 * sizeof(Real));
    to += 3 * sizeof(Real);
  }
  if (fields & kReadVelocity) {
    std::memcpy(to, p.velocity[i].data(), 3 * sizeof(Real));
    to += 3 * sizeof(Real);
  }
  if (fields & kReadDensity) std::memcpy(to, &p.density[i], sizeof(Real));
}

// `out` has the asked arrays sized; the record's values go to its entry `k`. Returns its id.
uint32_t RecordId(const std::byte* from) {
  uint32_t id;
  std::memcpy(&id, from, sizeof(uint32_t));
  return id;
}
void GetRecord(const std::byte* from, uint32_t fields, size_t k, ParticleArrays& out) {
  out.id[k] = RecordId(from);
  from += sizeof(uint32_t);
  if (fields & kReadPosition) {
    std::memcpy(out.position[k].data(), from, 3 * sizeof(Real));
    from += 3 * sizeof(Real);
  }
  if (fields & kReadVelocity) {
    std::memcpy(out.velocity[k].data(), from, 3 * sizeof(Real));
    from += 3 * sizeof(Real);
  }
  if (fields & kReadDensity) std::memcpy(&out.density[k], from, sizeof(Real));
}

ParticleArrays SizedFor(size_t n, uint32_t fields) {
  ParticleArrays p;
  p.id.resize(n);
  if (fields & kReadPosition) p.position.resize(n);
  if (fields & kReadVelocity) p.velocity.resize(n);
  if (fields & kReadDensity) p.density.resize(n);
  return p;
}

template <class T>
void Append(Bytes& out, const T& value) {
  const auto* from = reinterpret_cast<const std::byte*>(&value);
  out.insert(out.end(), from, from + sizeof(T));
}
template <class T>
T Read(const std::byte* from) {
  T value;
  std::memcpy(&value, from, sizeof(T));
  return value;
}

// A view candidate's place in the selection's one strict order: key, then id (ViewKeys::Select
// breaks ties by the candidate index, id / stride: the same order).
struct Keyed {
  float key;
  uint32_t id;
  bool operator<(const Keyed& o) const { return key < o.key || (key == o.key && id < o.id); }
};

}  // namespace

ParticleArrays DistributedSimulation::GatherParticlesByIds(std::span<const uint32_t> ids,
                                                           uint32_t fields) const {
  const ParticleArrays& p = state_.particles;
  // (id, place in `ids`), by id: which of this process's particles are asked for (a binary
  // search per owned particle), and on process 0 where each answer goes.
  std::vector<std::pair<uint32_t, size_t>> asked(ids.size());
  for (size_t k = 0; k < ids.size(); ++k) asked[k] = {ids[k], k};
  std::sort(asked.begin(), asked.end());
  const auto first_of = [&](uint32_t id) {
    return std::lower_bound(asked.begin(), asked.end(), std::pair<uint32_t, size_t>(id, 0));
  };
  Bytes mine;
  for (size_t i = 0; i < p.size(); ++i) {
    const auto at = first_of(p.id[i]);
    if (at != asked.end() && at->first == p.id[i]) PutRecord(p, i, fields, mine);
  }
  const std::vector<Bytes> parts = comm_.GatherToRoot(mine);
  if (comm_.rank() != 0) return {};
  ParticleArrays out = SizedFor(ids.size(), fields);
  const size_t record = RecordSize(fields);
  size_t placed = 0;
  for (const Bytes& part : parts) {
    for (size_t at = 0; at + record <= part.size(); at += record) {
      const uint32_t id = RecordId(part.data() + at);
      // Every place that asked for it (an id asked twice is answered twice).
      for (auto it = first_of(id); it != asked.end() && it->first == id; ++it, ++placed) {
        GetRecord(part.data() + at, fields, it->second, out);
      }
    }
  }
  if (placed != ids.size()) {
    throw std::logic_error("GatherParticlesByIds: the processes owned " + std::to_string(placed) +
                           " of the " + std::to_string(ids.size()) + " particles asked for");
  }
  return out;
}

Simulation::PositionBounds DistributedSimulation::PositionBounds() const {
  // Per axis this process's extremes as Simulation's BoundsOf takes them (std::min and std::max
  // skip a NaN; from +-inf, every NaN is skipped), and its first zero in key order (one
  // process's storage order), whose sign a zero extreme takes there: 20 bytes an axis to
  // process 0, which takes the extremes over the processes (exact) and, for a zero extreme, the
  // sign of the zero first in key order.
  const ParticleArrays& p = state_.particles;
  constexpr uint64_t kNoZero = std::numeric_limits<uint64_t>::max();
  Bytes mine;
  for (int a = 0; a < 3; ++a) {
    float lo = std::numeric_limits<float>::infinity();
    float hi = -lo;
    uint64_t zero_key = kNoZero;
    float zero = 0;
    for (size_t i = 0; i < p.size(); ++i) {
      const float x = p.position[i][a];
      lo = std::min(lo, x);
      hi = std::max(hi, x);
      if (x == 0 && keys_[i] < zero_key) {
        zero_key = keys_[i];
        zero = x;
      }
    }
    Append(mine, lo);
    Append(mine, hi);
    Append(mine, zero_key);
    Append(mine, zero);
  }
  const std::vector<Bytes> parts = comm_.GatherToRoot(mine);
  Simulation::PositionBounds b;
  if (comm_.rank() != 0) return b;
  constexpr size_t kAxis = 2 * sizeof(float) + sizeof(uint64_t) + sizeof(float);
  for (int a = 0; a < 3; ++a) {
    float lo = std::numeric_limits<float>::infinity();
    float hi = -lo;
    uint64_t zero_key = kNoZero;
    float zero = 0;
    for (const Bytes& part : parts) {
      const std::byte* at = part.data() + a * kAxis;
      lo = std::min(lo, Read<float>(at));
      hi = std::max(hi, Read<float>(at + 4));
      const uint64_t key = Read<uint64_t>(at + 8);
      if (key < zero_key) {
        zero_key = key;
        zero = Read<float>(at + 16);
      }
    }
    b.lo[a] = lo == 0 ? zero : lo;
    b.hi[a] = hi == 0 ? zero : hi;
  }
  return b;
}

GatheredViewSubset DistributedSimulation::SelectViewSubset(const ViewSubsetRequest& request,
                                                           uint64_t budget, uint32_t fields) const {
  const ParticleArrays& p = state_.particles;
  const uint32_t stride = std::max<uint32_t>(1, request.stride);
  // The grid, as ViewKeys makes it: on an axis where the box is degenerate, over every
  // particle's bounds (as doubles, NaN skipped; min and max are exact in any order).
  double particle_min[3], particle_max[3];
  bool degenerate = false;
  for (int a = 0; a < 3; ++a) {
    particle_min[a] = std::numeric_limits<double>::infinity();
    particle_max[a] = -particle_min[a];
    degenerate = degenerate || !(request.box_max[a] > request.box_min[a]);
  }
  if (degenerate) {
    std::array<double, 6> m;
    for (int a = 0; a < 3; ++a) {
      for (size_t i = 0; i < p.size(); ++i) {
        particle_min[a] = std::min(particle_min[a], double(p.position[i][a]));
        particle_max[a] = std::max(particle_max[a], double(p.position[i][a]));
      }
      m[a] = -particle_min[a];
      m[3 + a] = particle_max[a];
    }
    comm_.MaxInPlace(m);
    for (int a = 0; a < 3; ++a) {
      particle_min[a] = -m[a];
      particle_max[a] = m[3 + a];
    }
  }
  const ViewGrid grid = MakeViewGrid(request.box_min.data(), request.box_max.data(), particle_min,
                                     particle_max, size_t(total_));
  // This process's candidates and their cells; the cells' counts go to process 0 (8 bytes per
  // cell holding one of them), which weighs the cells and sends each process back the weights
  // of its cells (8 bytes each), in the order it listed them.
  std::vector<size_t> candidates;
  for (size_t i = 0; i < p.size(); ++i) {
    if (p.id[i] % stride == 0) candidates.push_back(i);
  }
  std::vector<uint32_t> cell_of(candidates.size());
  std::vector<uint32_t> count(kViewCells, 0);
  for (size_t c = 0; c < candidates.size(); ++c) {
    const Vec3& x = p.position[candidates[c]];
    cell_of[c] = ViewCellOf(grid, x[0], x[1], x[2]);
    ++count[cell_of[c]];
  }
  std::vector<uint32_t> my_cells;
  Bytes counts;
  for (uint32_t cell = 0; cell < kViewCells; ++cell) {
    if (count[cell] == 0) continue;
    my_cells.push_back(cell);
    Append(counts, cell);
    Append(counts, count[cell]);
  }
  const std::vector<Bytes> counted = comm_.GatherToRoot(counts);
  std::vector<Bytes> weights_to(size_t(comm_.size()));
  if (comm_.rank() == 0) {
    std::vector<uint32_t> total(kViewCells, 0);
    for (const Bytes& part : counted) {
      for (size_t at = 0; at + 8 <= part.size(); at += 8) {
        total[Read<uint32_t>(part.data() + at)] += Read<uint32_t>(part.data() + at + 4);
      }
    }
    if (!request.weigh) throw std::invalid_argument("SelectViewSubset: the request has no weigher");
    std::vector<double> weight(kViewCells, 0);
    request.weigh(grid, total.data(), weight.data());
    for (size_t q = 0; q < counted.size(); ++q) {
      for (size_t at = 0; at + 8 <= counted[q].size(); at += 8) {
        Append(weights_to[q], weight[Read<uint32_t>(counted[q].data() + at)]);
      }
    }
  }
  const Bytes weights = std::move(comm_.AllToAll(weights_to)[0]);
  if (weights.size() != my_cells.size() * sizeof(double)) {
    throw std::logic_error("SelectViewSubset: process 0 sent weights for another set of cells");
  }
  std::vector<double> weight(kViewCells, 0);
  for (size_t c = 0; c < my_cells.size(); ++c) {
    weight[my_cells[c]] = Read<double>(weights.data() + c * sizeof(double));
  }
  // This process's candidates in the selection's order: each process's share of the `budget`
  // smallest is a prefix of its own order, at most `budget` long.
  std::vector<Keyed> keyed(candidates.size());
  std::vector<uint32_t> order(candidates.size());
  for (size_t c = 0; c < candidates.size(); ++c) {
    const uint32_t id = p.id[candidates[c]];
    keyed[c] = {ViewKey(id, weight[cell_of[c]]), id};
    order[c] = uint32_t(c);
  }
  const auto before = [&](uint32_t a, uint32_t b) { return keyed[a] < keyed[b]; };
  const size_t longest = size_t(std::min<uint64_t>(budget, order.size()));
  std::partial_sort(order.begin(), order.begin() + longest, order.end(), before);
  order.resize(longest);
  // Unless the budget takes every candidate (known to all from one integer sum), process 0
  // merges the processes' prefixes (8 bytes a pair) and tells each how much of its own is in.
  std::vector<int64_t> all_candidates{int64_t(candidates.size())};
  comm_.SumInPlace(all_candidates);
  size_t taken = longest;
  if (budget < uint64_t(all_candidates[0])) {
    Bytes pairs;
    for (const uint32_t c : order) {
      Append(pairs, keyed[c].key);
      Append(pairs, keyed[c].id);
    }
    const std::vector<Bytes> offered = comm_.GatherToRoot(pairs);
    std::vector<Bytes> take_to(size_t(comm_.size()));
    if (comm_.rank() == 0) {
      std::vector<std::pair<Keyed, size_t>> merged;  // (pair, process)
      for (size_t q = 0; q < offered.size(); ++q) {
        for (size_t at = 0; at + 8 <= offered[q].size(); at += 8) {
          merged.push_back(
              {{Read<float>(offered[q].data() + at), Read<uint32_t>(offered[q].data() + at + 4)},
               q});
        }
      }
      const auto by_key = [](const auto& a, const auto& b) { return a.first < b.first; };
      std::nth_element(merged.begin(), merged.begin() + budget, merged.end(), by_key);
      std::vector<uint64_t> in(offered.size(), 0);
      for (size_t k = 0; k < budget; ++k) ++in[merged[k].second];
      for (size_t q = 0; q < offered.size(); ++q) Append(take_to[q], in[q]);
    }
    taken = size_t(Read<uint64_t>(comm_.AllToAll(take_to)[0].data()));
  }
  // Only the chosen particles cross; process 0 puts them in id order.
  Bytes chosen;
  for (size_t k = 0; k < taken; ++k) PutRecord(p, candidates[order[k]], fields, chosen);
  const std::vector<Bytes> parts = comm_.GatherToRoot(chosen);
  GatheredViewSubset out;
  if (comm_.rank() != 0) return out;
  const size_t record = RecordSize(fields);
  std::vector<std::pair<uint32_t, const std::byte*>> got;
  for (const Bytes& part : parts) {
    for (size_t at = 0; at + record <= part.size(); at += record) {
      got.push_back({RecordId(part.data() + at), part.data() + at});
    }
  }
  std::sort(got.begin(), got.end());
  out.particles = SizedFor(got.size(), fields);
  out.ids.resize(got.size());
  for (size_t k = 0; k < got.size(); ++k) {
    out.ids[k] = got[k].first;
    GetRecord(got[k].second, fields, k, out.particles);
  }
  return out;
}

}  // namespace dysa::distributed
