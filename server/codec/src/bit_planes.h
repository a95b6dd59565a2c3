// The payload's layout (FORMAT.md, "Payload"): each component's zig-zag residuals z are split at
// a bit chosen per component and chunk; the high parts z >> split, small and skewed, go to zstd
// as byte planes, and the low split bits, close to uniformly random for noisy residuals, are
// packed beside it as they are.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "components.h"

namespace dysa::codec {

// Lays out the residuals of `n` components (m each, one after the other in z): into `raw` (to be
// compressed) the two bytes split and planes per component, then the byte planes; into
// `low_bits` the packed low bits. Both are overwritten.
void WritePlanes(const uint32_t* z, size_t n, uint32_t m, std::vector<uint8_t>& raw,
                 std::vector<uint8_t>& low_bits);

// The largest decompressed payload of n components of m particles: two bytes and at most four
// planes per component. A decoder checks a header's raw_size against it before it allocates.
uint64_t MaxRawSize(int n, uint32_t m);

// Where each component's residuals lie in a decompressed payload and its packed low bits.
// Slots: the components, plus the ids of a keyframe with explicit ids (FORMAT.md, "Ids").
inline constexpr int kMaxSlots = kComponents + 1;
struct PlaneLayout {
  int split[kMaxSlots] = {};
  int planes[kMaxSlots] = {};
  size_t plane_at[kMaxSlots] = {};  // offset of the component's first plane in raw
  size_t bits_at[kMaxSlots] = {};   // offset of the component's packed bits
};

// Reads the split and plane count of each of n components from `raw` and checks that the planes
// fill `raw` and the packed bits fill bits_size bytes exactly. Returns an error message, empty on
// success.
std::string ReadPlaneLayout(std::span<const uint8_t> raw, size_t bits_size, int n, uint32_t m,
                            PlaneLayout& layout);

// Rebuilds the residuals z = (high << split) | low of component `slot` (m values). Returns an
// error message, empty on success.
std::string ReadResiduals(std::span<const uint8_t> raw, std::span<const uint8_t> bits,
                          const PlaneLayout& layout, int slot, uint32_t m, uint32_t* z);

}  // namespace dysa::codec
