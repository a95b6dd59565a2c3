#include "npz_writer.h"

#include <array>
#include <bit>
#include <limits>
#include <stdexcept>

namespace dysa {
namespace {

// Arrays are written as they lie in memory and declared little-endian ("<f4").
static_assert(std::endian::native == std::endian::little, "the .npy writer assumes little-endian");

constexpr std::array<uint32_t, 256> MakeCrcTable() {
  std::array<uint32_t, 256> table{};
  for (uint32_t n = 0; n < 256; ++n) {
    uint32_t c = n;
    for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
    table[n] = c;
  }
  return table;
}
constexpr std::array<uint32_t, 256> kCrcTable = MakeCrcTable();

// ZIP fields are little-endian; appended byte by byte so the layout is explicit.
void Put16(std::string& out, uint32_t value) {
  out.push_back(char(value & 0xFF));
  out.push_back(char((value >> 8) & 0xFF));
}
void Put32(std::string& out, uint32_t value) {
  Put16(out, value & 0xFFFF);
  Put16(out, value >> 16);
}

// 1980-01-01 00:00, the earliest DOS date: a fixed timestamp keeps the output reproducible.
constexpr uint32_t kDosTime = 0;
constexpr uint32_t kDosDate = (1 << 5) | 1;
constexpr uint32_t kVersionNeeded = 20;
constexpr uint32_t kMaxZip32 = std::numeric_limits<uint32_t>::max();

template <class T>
std::span<const uint8_t> AsBytes(std::span<const T> values) {
  return {reinterpret_cast<const uint8_t*>(values.data()), values.size_bytes()};
}

}  // namespace

uint32_t Crc32(std::span<const uint8_t> bytes, uint32_t crc) {
  crc = ~crc;
  for (uint8_t b : bytes) crc = kCrcTable[(crc ^ b) & 0xFF] ^ (crc >> 8);
  return ~crc;
}

std::string NpyHeader(const std::string& descr, std::span<const size_t> shape) {
  std::string dict = "{'descr': '" + descr + "', 'fortran_order': False, 'shape': (";
  for (size_t i = 0; i < shape.size(); ++i) {
    dict += std::to_string(shape[i]);
    if (i + 1 < shape.size() || shape.size() == 1) dict += ",";  // (N,) is a 1-tuple
    if (i + 1 < shape.size()) dict += " ";
  }
  dict += "), }";
  // Magic (6) + version (2) + length (2) + dictionary + spaces + '\n', a multiple of 64
  // (NumPy's own alignment, so the data can be memory-mapped aligned).
  const size_t unpadded = 10 + dict.size() + 1;
  dict.append((64 - unpadded % 64) % 64, ' ');
  dict += '\n';
  if (dict.size() > 0xFFFF) throw std::runtime_error("npy header too long");
  std::string header = "\x93NUMPY";
  header.push_back(1);
  header.push_back(0);
  Put16(header, uint32_t(dict.size()));
  return header + dict;
}

NpzWriter::NpzWriter(std::filesystem::path path)
    : path_(std::move(path)), file_(path_, std::ios::binary | std::ios::trunc) {
  if (!file_) throw std::runtime_error("cannot write " + path_.string());
}

NpzWriter::~NpzWriter() {
  if (!closed_) {
    try {
      Close();
    } catch (const std::exception&) {
      // A destructor cannot report it; callers that care call Close().
    }
  }
}

void NpzWriter::Add(const std::string& name, std::span<const float> values,
                    std::vector<size_t> shape) {
  AddRaw(name, "<f4", AsBytes(values), sizeof(float), shape);
}
void NpzWriter::Add(const std::string& name, std::span<const double> values,
                    std::vector<size_t> shape) {
  AddRaw(name, "<f8", AsBytes(values), sizeof(double), shape);
}
void NpzWriter::Add(const std::string& name, std::span<const uint32_t> values,
                    std::vector<size_t> shape) {
  AddRaw(name, "<u4", AsBytes(values), sizeof(uint32_t), shape);
}
void NpzWriter::Add(const std::string& name, std::span<const uint64_t> values,
                    std::vector<size_t> shape) {
  AddRaw(name, "<u8", AsBytes(values), sizeof(uint64_t), shape);
}

void NpzWriter::AddRaw(const std::string& name, const std::string& descr,
                       std::span<const uint8_t> data, size_t element_size,
                       const std::vector<size_t>& shape) {
  if (closed_)
    throw std::runtime_error(path_.string() + ": array '" + name + "' added after Close");
  size_t elements = 1;
  for (size_t extent : shape) elements *= extent;
  if (elements * element_size != data.size()) {
    throw std::runtime_error(path_.string() + ": array '" + name + "' has " +
                             std::to_string(data.size() / element_size) +
                             " elements, its shape needs " + std::to_string(elements));
  }
  Entry entry;
  entry.file_name = name + ".npy";
  const std::string npy_header = NpyHeader(descr, shape);
  const uint64_t size = npy_header.size() + data.size();
  const uint64_t end = offset_ + 30 + entry.file_name.size() + size;
  if (size >= kMaxZip32 || end >= kMaxZip32) {
    throw std::runtime_error(path_.string() + ": array '" + name +
                             "' would pass 4 GiB, the limit of a .npz without ZIP64");
  }
  entry.size = uint32_t(size);
  entry.offset = uint32_t(offset_);
  entry.crc =
      Crc32(data, Crc32({reinterpret_cast<const uint8_t*>(npy_header.data()), npy_header.size()}));

  std::string local;
  Put32(local, 0x04034b50);  // local file header signature
  Put16(local, kVersionNeeded);
  Put16(local, 0);  // flags
  Put16(local, 0);  // method: stored
  Put16(local, kDosTime);
  Put16(local, kDosDate);
  Put32(local, entry.crc);
  Put32(local, entry.size);  // compressed size
  Put32(local, entry.size);  // uncompressed size
  Put16(local, uint32_t(entry.file_name.size()));
  Put16(local, 0);  // extra field length
  local += entry.file_name;
  local += npy_header;
  file_.write(local.data(), std::streamsize(local.size()));
  file_.write(reinterpret_cast<const char*>(data.data()), std::streamsize(data.size()));
  if (!file_) throw std::runtime_error("error writing " + path_.string());
  offset_ = end;
  entries_.push_back(std::move(entry));
}

void NpzWriter::Close() {
  if (closed_) return;
  closed_ = true;
  std::string directory;
  for (const Entry& e : entries_) {
    Put32(directory, 0x02014b50);      // central directory header signature
    Put16(directory, kVersionNeeded);  // version made by (MS-DOS attributes)
    Put16(directory, kVersionNeeded);
    Put16(directory, 0);  // flags
    Put16(directory, 0);  // method: stored
    Put16(directory, kDosTime);
    Put16(directory, kDosDate);
    Put32(directory, e.crc);
    Put32(directory, e.size);
    Put32(directory, e.size);
    Put16(directory, uint32_t(e.file_name.size()));
    Put16(directory, 0);  // extra field length
    Put16(directory, 0);  // comment length
    Put16(directory, 0);  // disk number
    Put16(directory, 0);  // internal attributes
    Put32(directory, 0);  // external attributes
    Put32(directory, e.offset);
    directory += e.file_name;
  }
  if (entries_.size() > 0xFFFF || offset_ + directory.size() + 22 >= kMaxZip32) {
    throw std::runtime_error(path_.string() + ": too large for a .npz without ZIP64");
  }
  std::string tail;
  Put32(tail, 0x06054b50);  // end of central directory signature
  Put16(tail, 0);           // this disk
  Put16(tail, 0);           // disk of the central directory
  Put16(tail, uint32_t(entries_.size()));
  Put16(tail, uint32_t(entries_.size()));
  Put32(tail, uint32_t(directory.size()));
  Put32(tail, uint32_t(offset_));
  Put16(tail, 0);  // comment length
  file_.write(directory.data(), std::streamsize(directory.size()));
  file_.write(tail.data(), std::streamsize(tail.size()));
  file_.close();
  if (!file_) throw std::runtime_error("error writing " + path_.string());
}

}  // namespace dysa
