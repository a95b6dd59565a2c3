#include "dysa/distributed/slabs.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace dysa::distributed {

Slabs::Slabs(int layers, int processes, bool periodic, int depth)
    : layers_(layers), periodic_(periodic), depth_(depth) {
  if (processes < 1 || layers < processes) {
    throw std::invalid_argument("the neighbour grid has " + std::to_string(layers) +
                                " cell layers along its longest axis, fewer than the " +
                                std::to_string(processes) +
                                " processes (ranks) that must each own one: run on at most " +
                                std::to_string(layers) + " ranks");
  }
  // Equal layer counts until the first Balance.
  cuts_.resize(size_t(processes) + 1);
  for (int p = 0; p <= processes; ++p) cuts_[p] = int(int64_t(layers) * p / processes);
  Index();
}

void Slabs::Balance(std::span<const int64_t> counts) {
  const int processes = this->processes();
  int64_t total = 0;
  for (int64_t c : counts) total += c;
  // prefix(l) = particles in the layers below l. Process k starts at the first l with
  // prefix(l) P >= k N; then each start is pushed up to leave every earlier process a layer,
  // and down to leave every later one a layer.
  int layer = 0;
  int64_t prefix = 0;
  for (int k = 1; k < processes; ++k) {
    while (layer < layers_ && prefix * processes < int64_t(k) * total) prefix += counts[layer++];
    cuts_[k] = std::clamp(layer, cuts_[k - 1] + 1, layers_ - (processes - k));
    // Keep the scan consistent with a cut the clamp moved.
    while (layer < cuts_[k]) prefix += counts[layer++];
  }
  Index();
}

void Slabs::SetCuts(std::span<const int> cuts) {
  bool valid = cuts.size() == cuts_.size() && cuts.front() == 0 && cuts.back() == layers_;
  for (size_t k = 1; valid && k < cuts.size(); ++k) valid = cuts[k] > cuts[k - 1];
  if (!valid) throw std::invalid_argument("slab cuts must ascend from 0 to the layer count");
  cuts_.assign(cuts.begin(), cuts.end());
  Index();
}

int Slabs::Distance(int layer, int p) const {
  const int b = cuts_[p];
  const int e = cuts_[p + 1] - 1;
  if (layer >= b && layer <= e) return 0;
  if (!periodic_) return layer < b ? b - layer : layer - e;
  // Around the ring: up from the layer to b, or down from it to e.
  const int up = ((b - layer) % layers_ + layers_) % layers_;
  const int down = ((layer - e) % layers_ + layers_) % layers_;
  return std::min(up, down);
}

void Slabs::Index() {
  owner_.assign(size_t(layers_), 0);
  for (int p = 0; p < processes(); ++p) {
    for (int l = cuts_[p]; l < cuts_[p + 1]; ++l) owner_[l] = p;
  }
  readers_.assign(size_t(layers_), {});
  for (int l = 0; l < layers_; ++l) {
    for (int p = 0; p < processes(); ++p) {
      if (p != owner_[l] && Distance(l, p) <= depth_) readers_[l].push_back(p);
    }
  }
}

}  // namespace dysa::distributed
