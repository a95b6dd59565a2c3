// Little-endian reads and writes of fixed-size values at byte offsets.
#pragma once

#include <cstdint>
#include <cstring>

namespace dysa::codec {

// The format is little-endian and so are the machines this builds for (x86-64, arm64).
static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "big-endian hosts need byte swaps");

template <class T>
inline void Put(uint8_t* at, T value) {
  std::memcpy(at, &value, sizeof(T));
}

template <class T>
inline T Get(const uint8_t* at) {
  T value;
  std::memcpy(&value, at, sizeof(T));
  return value;
}

}  // namespace dysa::codec
