// How frame_decoder_fuzzer reads its input (shared with make_corpus, which writes seeds in it).
//
//   byte 0   bits 0-1  delivery:  0  AddChunk per chunk, continuing after each DecodeError
//                                 1  AddChunks on all chunks at once
//                                 2  AddChunks on groups of `group` chunks, continuing after errors
//                                 3  differential, three fresh decoders:
//                                    A  AddChunks on all chunks;
//                                    B  AddChunk per chunk: when A threw nothing, B must throw
//                                       nothing either and return A's last frame;
//                                    C  AddChunks(chunk, Frame& out) per chunk, one `out` reused
//                                       and scribbled over between calls: in lockstep with B, the
//                                       same DecodeErrors and the same frames
//            bit 2     split:     0  length-prefixed: repeated [u32 LE length][length bytes],
//                                    the length clamped to what is left
//                                 1  at each "DYSF" magic (a chunk starts at every occurrence;
//                                    bytes before the first one are a chunk of their own)
//            bits 3-5  group - 1  (delivery 2): 1..8 chunks per AddChunks call
//            bit 6     recycle    (delivery 0-2): call AddChunks(chunks, Frame& out) with one
//                                 `out` for the whole input instead of the std::optional forms
//   bytes 1.. the chunks, split as above; at most kMaxChunks (the rest is ignored)
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

namespace dysa::fuzz {

enum Delivery : uint8_t { kPerChunk = 0, kAllAtOnce = 1, kGroups = 2, kDifferential = 3 };
enum Split : uint8_t { kLengthPrefixed = 0, kAtMagic = 1 };

inline constexpr size_t kMaxChunks = 64;
inline constexpr uint8_t kMagicBytes[4] = {'D', 'Y', 'S', 'F'};  // 0x46535944 little-endian

inline constexpr uint8_t kRecycle = 1u << 6;

inline uint8_t ModeByte(Delivery delivery, Split split, int group = 1, bool recycle = false) {
  return uint8_t(delivery | (split << 2) | ((group - 1) & 7) << 3 | (recycle ? kRecycle : 0));
}

// Splits `data` (without the mode byte) into chunks.
inline std::vector<std::vector<uint8_t>> SplitChunks(const uint8_t* data, size_t size,
                                                     Split split) {
  std::vector<std::vector<uint8_t>> chunks;
  if (split == kLengthPrefixed) {
    size_t at = 0;
    while (at < size && chunks.size() < kMaxChunks) {
      uint32_t length = 0;
      const size_t prefix = size - at < 4 ? size - at : 4;
      std::memcpy(&length, data + at, prefix);  // little-endian hosts only, as the codec
      at += prefix;
      const size_t n = length < size - at ? size_t(length) : size - at;
      chunks.emplace_back(data + at, data + at + n);
      at += n;
    }
    return chunks;
  }
  auto is_magic = [&](size_t i) {
    return i + 4 <= size && std::memcmp(data + i, kMagicBytes, 4) == 0;
  };
  size_t start = 0;
  for (size_t i = 1; i <= size && chunks.size() < kMaxChunks; ++i) {
    if (i == size || is_magic(i)) {
      chunks.emplace_back(data + start, data + i);
      start = i;
    }
  }
  return chunks;
}

// Writes chunks in the length-prefixed form.
inline void AppendLengthPrefixed(std::vector<uint8_t>& out, const std::vector<uint8_t>& chunk) {
  const uint32_t n = uint32_t(chunk.size());
  const uint8_t* p = reinterpret_cast<const uint8_t*>(&n);
  out.insert(out.end(), p, p + 4);
  out.insert(out.end(), chunk.begin(), chunk.end());
}

}  // namespace dysa::fuzz
