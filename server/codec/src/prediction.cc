#include "prediction.h"

#include <algorithm>

namespace dysa::codec {
namespace {

uint32_t ZigZag(int32_t r) { return (uint32_t(r) << 1) ^ uint32_t(r >> 31); }
int32_t UnZigZag(uint32_t z) { return int32_t(z >> 1) ^ -int32_t(z & 1); }

// Residuals of a delta frame, zig-zag mapped: cur[k] minus the prediction from the history
// (FORMAT.md); loops specialised by the prediction order.
void DeltaResiduals(const uint32_t* cur, const History& history, Component c, uint32_t first,
                    uint32_t m, uint32_t levels, uint32_t* z) {
  const uint32_t* a = history[0][c].data() + first;
  if (history.size() == 1) {
    for (uint32_t k = 0; k < m; ++k) z[k] = ZigZag(int32_t(int64_t(cur[k]) - a[k]));
    return;
  }
  const uint32_t* b = history[1][c].data() + first;
  const int64_t top = levels;
  if (history.size() == 2) {
    for (uint32_t k = 0; k < m; ++k) {
      const int64_t pred = std::clamp<int64_t>(2 * int64_t(a[k]) - b[k], 0, top);
      z[k] = ZigZag(int32_t(int64_t(cur[k]) - pred));
    }
    return;
  }
  const uint32_t* c3 = history[2][c].data() + first;
  for (uint32_t k = 0; k < m; ++k) {
    const int64_t pred = std::clamp<int64_t>(3 * (int64_t(a[k]) - b[k]) + c3[k], 0, top);
    z[k] = ZigZag(int32_t(int64_t(cur[k]) - pred));
  }
}

// The inverse: values from zig-zag residuals. False if a value leaves [0, levels].
bool UndoDeltaResiduals(const uint32_t* z, const History& history, Component c, uint32_t first,
                        uint32_t m, uint32_t levels, uint32_t* cur) {
  const uint32_t* a = history[0][c].data() + first;
  const uint32_t* b = history.size() > 1 ? history[1][c].data() + first : a;
  const uint32_t* c3 = history.size() > 2 ? history[2][c].data() + first : a;
  const int64_t top = levels;
  const size_t order = history.size();
  bool ok = true;
  for (uint32_t k = 0; k < m; ++k) {
    int64_t pred = a[k];
    if (order == 2) pred = std::clamp<int64_t>(2 * int64_t(a[k]) - b[k], 0, top);
    if (order == 3) pred = std::clamp<int64_t>(3 * (int64_t(a[k]) - b[k]) + c3[k], 0, top);
    const int64_t value = pred + UnZigZag(z[k]);
    ok &= value >= 0 && value <= top;
    cur[k] = uint32_t(value);
  }
  return ok;
}

}  // namespace

void PushHistory(History& history, Values&& q, bool keyframe, std::vector<Values>& spare) {
  if (keyframe) {
    for (Values& old : history) spare.push_back(std::move(old));
    history.clear();
  }
  history.insert(history.begin(), std::move(q));
  if (history.size() > 3) {
    spare.push_back(std::move(history.back()));
    history.pop_back();
  }
}

void Residuals(const ChunkHeader& h, Component c, const Values& q, const History& history,
               uint32_t* z) {
  const uint32_t m = h.chunk_particles;
  const uint32_t* cur = q[c].data() + h.first;
  if (h.keyframe()) {
    // The chunk's first particle is predicted by 0, so each chunk decodes on its own.
    for (uint32_t k = 0; k < m; ++k) {
      z[k] = ZigZag(int32_t(int64_t(cur[k]) - (k == 0 ? 0 : int64_t(cur[k - 1]))));
    }
  } else {
    DeltaResiduals(cur, history, c, h.first, m, Levels(h.Bits(c)), z);
  }
}

bool UndoResiduals(const ChunkHeader& h, Component c, const uint32_t* z, const History& history,
                   Values& q) {
  const uint32_t m = h.chunk_particles;
  const uint32_t levels = Levels(h.Bits(c));
  uint32_t* cur = q[c].data() + h.first;
  if (!h.keyframe()) return UndoDeltaResiduals(z, history, c, h.first, m, levels, cur);
  bool in_range = true;
  int64_t value = 0;
  for (uint32_t k = 0; k < m && in_range; ++k) {
    value += UnZigZag(z[k]);
    in_range = value >= 0 && value <= int64_t(levels);
    cur[k] = uint32_t(value);
  }
  return in_range;
}

}  // namespace dysa::codec
