#include "bit_planes.h"

#include <algorithm>

namespace dysa::codec {
namespace {

// The split k is chosen from the mean so that the high parts average a few units.
int SplitBitsFor(uint64_t sum_z, uint32_t m) {
  const uint64_t mean = m == 0 ? 0 : sum_z / m;
  int bit_length = 0;
  while ((mean >> bit_length) != 0) ++bit_length;
  return std::min(24, std::max(0, bit_length - 3));
}

size_t PackedBytes(uint32_t m, int k) { return (uint64_t(m) * uint64_t(k) + 7) / 8; }

// Appends the low k bits of each value, least significant bit first, padded to whole bytes.
void PackBits(const uint32_t* values, uint32_t m, int k, std::vector<uint8_t>& out) {
  if (k == 0) return;
  const size_t at = out.size();
  out.resize(at + PackedBytes(m, k));
  uint8_t* dst = out.data() + at;
  const uint32_t mask = (1u << k) - 1;
  uint64_t acc = 0;
  int filled = 0;
  for (uint32_t i = 0; i < m; ++i) {
    acc |= uint64_t(values[i] & mask) << filled;
    filled += k;
    while (filled >= 8) {
      *dst++ = uint8_t(acc);
      acc >>= 8;
      filled -= 8;
    }
  }
  if (filled > 0) *dst = uint8_t(acc);
}

int PlanesFor(uint32_t max_z) {
  int planes = 0;
  while (max_z != 0) ++planes, max_z >>= 8;
  return planes;
}

}  // namespace

void WritePlanes(const uint32_t* z, size_t n, uint32_t m, std::vector<uint8_t>& raw,
                 std::vector<uint8_t>& low_bits) {
  raw.assign(2 * n, 0);
  raw.reserve(2 * n + 4 * size_t(m) * n);
  low_bits.clear();
  for (size_t slot = 0; slot < n; ++slot) {
    const uint32_t* zs = z + slot * m;
    uint64_t sum_z = 0;
    for (uint32_t k = 0; k < m; ++k) sum_z += zs[k];
    const int split = SplitBitsFor(sum_z, m);
    uint32_t max_high = 0;
    for (uint32_t k = 0; k < m; ++k) max_high = std::max(max_high, zs[k] >> split);
    raw[2 * slot] = uint8_t(split);
    raw[2 * slot + 1] = uint8_t(PlanesFor(max_high));
    PackBits(zs, m, split, low_bits);
  }
  for (size_t slot = 0; slot < n; ++slot) {
    const uint32_t* zs = z + slot * m;
    const int split = raw[2 * slot];
    for (int p = 0; p < raw[2 * slot + 1]; ++p) {
      const size_t at = raw.size();
      raw.resize(at + m);
      uint8_t* plane = raw.data() + at;
      const int shift = split + 8 * p;
      for (uint32_t k = 0; k < m; ++k) plane[k] = uint8_t(zs[k] >> shift);
    }
  }
}

uint64_t MaxRawSize(int n, uint32_t m) { return uint64_t(n) * (2 + 4 * uint64_t(m)); }

std::string ReadPlaneLayout(std::span<const uint8_t> raw, size_t bits_size, int n, uint32_t m,
                            PlaneLayout& layout) {
  if (raw.size() < 2 * size_t(n)) return "payload too short";
  size_t expected = 2 * size_t(n);
  size_t expected_bits = 0;
  for (int s = 0; s < n; ++s) {
    if (raw[2 * s] > 24) return "split beyond 24 bits";
    if (raw[2 * s + 1] > 4) return "more than 4 byte planes";
    layout.split[s] = raw[2 * s];
    layout.planes[s] = raw[2 * s + 1];
    layout.plane_at[s] = expected;
    layout.bits_at[s] = expected_bits;
    expected += size_t(layout.planes[s]) * m;
    expected_bits += PackedBytes(m, layout.split[s]);
  }
  if (expected != raw.size()) return "payload size does not match its byte planes";
  if (expected_bits != bits_size) return "packed bits do not match their split";
  return {};
}

std::string ReadResiduals(std::span<const uint8_t> raw, std::span<const uint8_t> bits,
                          const PlaneLayout& layout, int slot, uint32_t m, uint32_t* z) {
  const int split = layout.split[slot];
  const int planes = layout.planes[slot];
  if (split + 8 * planes > 32) return "residual wider than 32 bits";
  // z = (high << split) | low, high from the byte planes, low from the packed bits.
  if (planes == 0) std::fill(z, z + m, 0u);
  for (int p = 0; p < planes; ++p) {
    const uint8_t* plane = raw.data() + layout.plane_at[slot] + size_t(p) * m;
    const int shift = split + 8 * p;
    if (p == 0) {
      for (uint32_t k = 0; k < m; ++k) z[k] = uint32_t(plane[k]) << shift;
    } else {
      for (uint32_t k = 0; k < m; ++k) z[k] |= uint32_t(plane[k]) << shift;
    }
  }
  if (split > 0) {
    const uint8_t* packed = bits.data() + layout.bits_at[slot];
    const uint64_t mask = (uint64_t{1} << split) - 1;
    uint64_t acc = 0;
    int filled = 0;
    for (uint32_t k = 0; k < m; ++k) {
      while (filled < split) {
        acc |= uint64_t(*packed++) << filled;
        filled += 8;
      }
      z[k] |= uint32_t(acc & mask);
      acc >>= split;
      filled -= split;
    }
  }
  return {};
}

}  // namespace dysa::codec
