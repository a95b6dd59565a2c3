// NumPy .npz output: a ZIP archive of .npy arrays, as numpy.savez writes it (stored, not
// compressed: particle positions barely compress, and it keeps the writer free of zlib).
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <span>
#include <string>
#include <vector>

namespace dysa {

// CRC-32 (IEEE 802.3, the ZIP checksum) of `bytes`, continuing from `crc` (0 to start).
uint32_t Crc32(std::span<const uint8_t> bytes, uint32_t crc = 0);

// The .npy encoding (format version 1.0) of an array's header: magic, version, length and the
// dictionary, padded so that the data starts at a multiple of 64 bytes. `descr` is a NumPy
// type string such as "<f4".
std::string NpyHeader(const std::string& descr, std::span<const size_t> shape);

// Writes arrays one by one into a new .npz file, each as NAME.npy; Close() writes the ZIP
// central directory. Arrays are little-endian, C order. Members are limited to 4 GiB (no
// ZIP64). Throws std::runtime_error naming the file on I/O failure or misuse.
class NpzWriter {
 public:
  explicit NpzWriter(std::filesystem::path path);
  ~NpzWriter();  // closes if Close() was not called, ignoring errors
  NpzWriter(const NpzWriter&) = delete;
  NpzWriter& operator=(const NpzWriter&) = delete;

  // The product of `shape` must equal values.size().
  void Add(const std::string& name, std::span<const float> values, std::vector<size_t> shape);
  void Add(const std::string& name, std::span<const double> values, std::vector<size_t> shape);
  void Add(const std::string& name, std::span<const uint32_t> values, std::vector<size_t> shape);
  void Add(const std::string& name, std::span<const uint64_t> values, std::vector<size_t> shape);
  void Close();

 private:
  struct Entry {
    std::string file_name;
    uint32_t crc = 0;
    uint32_t size = 0;
    uint32_t offset = 0;
  };
  void AddRaw(const std::string& name, const std::string& descr, std::span<const uint8_t> data,
              size_t element_size, const std::vector<size_t>& shape);

  std::filesystem::path path_;
  std::ofstream file_;
  std::vector<Entry> entries_;
  uint64_t offset_ = 0;
  bool closed_ = false;
};

}  // namespace dysa
