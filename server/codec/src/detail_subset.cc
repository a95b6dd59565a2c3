#include "dysa/codec/detail_subset.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace dysa::codec {

uint32_t DetailThreshold(double fraction) {
  if (!std::isfinite(fraction) || fraction <= 0) {
    throw std::invalid_argument("detail fraction: allowed range (0, 1]");
  }
  if (fraction >= 1) return 0;
  const double t = std::ceil(fraction * 4294967296.0);
  return t >= 4294967295.0 ? 0xFFFFFFFFu : uint32_t(std::max(1.0, t));
}

double DetailFraction(uint32_t threshold) {
  return threshold == 0 ? 1.0 : double(threshold) / 4294967296.0;
}

std::vector<uint32_t> KeptIds(size_t ids, uint32_t stride, uint32_t threshold) {
  std::vector<uint32_t> kept;
  if (stride == 0) return kept;
  kept.reserve(threshold == 0
                   ? ids / stride + 1
                   : size_t(double(ids) / stride * DetailFraction(threshold) * 1.1) + 16);
  for (size_t id = 0; id < ids; id += stride) {
    if (DetailKeeps(uint32_t(id), stride, threshold)) kept.push_back(uint32_t(id));
  }
  return kept;
}

bool FirstKeptIds(uint32_t count, uint32_t stride, uint32_t threshold, uint32_t limit,
                  std::vector<uint32_t>& out) {
  out.resize(count);
  if (stride == 0) return count == 0;
  uint32_t found = 0;
  for (uint64_t id = 0; found < count && id < limit; id += stride) {
    if (DetailKeeps(uint32_t(id), stride, threshold)) out[found++] = uint32_t(id);
  }
  return found == count;
}

}  // namespace dysa::codec
