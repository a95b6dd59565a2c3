// The entropy coding stage (FORMAT.md, "Chunk header": payload_size bytes of one zstd frame that
// decompresses to exactly raw_size bytes). Each thread keeps one zstd context between calls, so
// chunks compress and decompress in parallel without a context per call.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace dysa::codec {

// Compresses `raw` as one zstd frame into `out` (grown as needed, never shrunk: it is reused),
// setting `size` to its length. Returns an error message, empty on success.
std::string Compress(std::span<const uint8_t> raw, int level, std::vector<uint8_t>& out,
                     size_t& size);

// Decompresses `payload`, which must be one zstd frame declaring raw_size bytes, no more than
// max_raw_size, into `raw`. Returns an error message, empty on success.
std::string Decompress(std::span<const uint8_t> payload, uint32_t raw_size, uint64_t max_raw_size,
                       std::vector<uint8_t>& raw);

}  // namespace dysa::codec
