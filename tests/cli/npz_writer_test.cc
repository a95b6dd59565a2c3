// Tests of clients/cli/npz_writer.h: the CRC-32, the .npy header, the ZIP structure read back
// in C++, and the file loaded by NumPy itself (/usr/bin/python3 with numpy).
#include "npz_writer.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <numeric>
#include <string>
#include <vector>

#include "support/temp_dir.h"

namespace dysa {
namespace {

namespace fs = std::filesystem;
using dysa::testing::ReadFile;
using ::testing::HasSubstr;

struct TempDir : dysa::testing::TempDir {
  TempDir() : dysa::testing::TempDir("dysa_npz") {}
};

std::span<const uint8_t> Bytes(const std::string& text) {
  return {reinterpret_cast<const uint8_t*>(text.data()), text.size()};
}

TEST(Crc32Test, MatchesTheStandardCheckValues) {
  EXPECT_EQ(Crc32(Bytes("")), 0u);
  EXPECT_EQ(Crc32(Bytes("123456789")), 0xCBF43926u);  // the CRC-32/ISO-HDLC check value
  EXPECT_EQ(Crc32(Bytes("The quick brown fox jumps over the lazy dog")), 0x414FA339u);
  // Continuing a CRC over a second part gives the CRC of the whole.
  EXPECT_EQ(Crc32(Bytes("6789"), Crc32(Bytes("12345"))), 0xCBF43926u);
}

TEST(NpyHeaderTest, IsAlignedAndDescribesTheArray) {
  const std::vector<size_t> shape3 = {5, 7, 3};
  const std::string h = NpyHeader("<f4", shape3);
  ASSERT_GE(h.size(), 10u);
  EXPECT_EQ(h.substr(0, 6), "\x93NUMPY");
  EXPECT_EQ(h[6], 1);
  EXPECT_EQ(h[7], 0);
  EXPECT_EQ(h.size() % 64, 0u);
  EXPECT_EQ(size_t(uint8_t(h[8]) | uint8_t(h[9]) << 8), h.size() - 10);
  EXPECT_EQ(h.back(), '\n');
  EXPECT_THAT(h, HasSubstr("{'descr': '<f4', 'fortran_order': False, 'shape': (5, 7, 3), }"));
  const std::vector<size_t> shape1 = {4};
  EXPECT_THAT(NpyHeader("<u8", shape1), HasSubstr("'shape': (4,), }"));
}

uint32_t Get16(const std::string& s, size_t at) {
  return uint32_t(uint8_t(s.at(at))) | uint32_t(uint8_t(s.at(at + 1))) << 8;
}
uint32_t Get32(const std::string& s, size_t at) { return Get16(s, at) | Get16(s, at + 2) << 16; }

// The test arrays: values follow a formula the Python check recomputes.
struct Sample {
  static constexpr size_t kFrames = 3, kParticles = 5;
  std::vector<float> positions;  // (F, N, 3): f * 100 + n + c / 4
  std::vector<float> speed;      // (F, N): f + n / 8
  std::vector<double> time;      // (F): f / 60
  std::vector<uint64_t> step;    // (F): 3 f + 2^40
  std::vector<uint32_t> ids;     // (N): 2 n

  Sample() {
    for (size_t f = 0; f < kFrames; ++f) {
      for (size_t n = 0; n < kParticles; ++n) {
        for (size_t c = 0; c < 3; ++c) positions.push_back(float(f * 100 + n) + float(c) / 4);
        speed.push_back(float(f) + float(n) / 8);
      }
      time.push_back(double(f) / 60);
      step.push_back(3 * f + (uint64_t{1} << 40));
    }
    for (size_t n = 0; n < kParticles; ++n) ids.push_back(uint32_t(2 * n));
  }

  void Write(const fs::path& path) const {
    NpzWriter npz(path);
    npz.Add("positions", std::span<const float>(positions), {kFrames, kParticles, 3});
    npz.Add("speed", std::span<const float>(speed), {kFrames, kParticles});
    npz.Add("time", std::span<const double>(time), {kFrames});
    npz.Add("step", std::span<const uint64_t>(step), {kFrames});
    npz.Add("ids", std::span<const uint32_t>(ids), {kParticles});
    npz.Close();
  }
};

TEST(NpzWriterTest, WritesAValidStoredZipOfNpyMembers) {
  TempDir dir;
  const fs::path path = dir.path() / "sample.npz";
  const Sample sample;
  sample.Write(path);
  const std::string zip = ReadFile(path);

  // End of central directory: the last 22 bytes (no comment).
  ASSERT_GE(zip.size(), 22u);
  const size_t eocd = zip.size() - 22;
  ASSERT_EQ(Get32(zip, eocd), 0x06054b50u);
  const uint32_t entries = Get16(zip, eocd + 10);
  const uint32_t directory_size = Get32(zip, eocd + 12);
  const uint32_t directory_offset = Get32(zip, eocd + 16);
  EXPECT_EQ(entries, 5u);
  EXPECT_EQ(Get16(zip, eocd + 8), entries);
  EXPECT_EQ(directory_offset + directory_size, eocd);

  std::map<std::string, std::string> members;  // name -> stored bytes
  size_t at = directory_offset;
  for (uint32_t e = 0; e < entries; ++e) {
    ASSERT_EQ(Get32(zip, at), 0x02014b50u) << "entry " << e;
    EXPECT_EQ(Get16(zip, at + 10), 0u);  // stored
    const uint32_t crc = Get32(zip, at + 16);
    const uint32_t compressed = Get32(zip, at + 20);
    const uint32_t size = Get32(zip, at + 24);
    const uint32_t name_length = Get16(zip, at + 28);
    const uint32_t extra = Get16(zip, at + 30);
    const uint32_t comment = Get16(zip, at + 32);
    const uint32_t local = Get32(zip, at + 42);
    const std::string name = zip.substr(at + 46, name_length);
    EXPECT_EQ(compressed, size) << name;

    // The local header repeats the central directory's fields.
    ASSERT_EQ(Get32(zip, local), 0x04034b50u) << name;
    EXPECT_EQ(Get16(zip, local + 8), 0u) << name;
    EXPECT_EQ(Get32(zip, local + 14), crc) << name;
    EXPECT_EQ(Get32(zip, local + 18), size) << name;
    EXPECT_EQ(Get32(zip, local + 22), size) << name;
    ASSERT_EQ(Get16(zip, local + 26), name_length) << name;
    EXPECT_EQ(zip.substr(local + 30, name_length), name);
    const size_t data = local + 30 + name_length + Get16(zip, local + 28);
    const std::string content = zip.substr(data, size);
    EXPECT_EQ(Crc32(Bytes(content)), crc) << name;
    members[name] = content;
    at += 46 + name_length + extra + comment;
  }
  EXPECT_EQ(at, eocd);

  ASSERT_EQ(members.count("positions.npy"), 1u);
  const std::string& positions = members["positions.npy"];
  const std::vector<size_t> shape = {Sample::kFrames, Sample::kParticles, 3};
  const std::string header = NpyHeader("<f4", shape);
  ASSERT_EQ(positions.size(), header.size() + sample.positions.size() * sizeof(float));
  EXPECT_EQ(positions.substr(0, header.size()), header);
  EXPECT_EQ(std::memcmp(positions.data() + header.size(), sample.positions.data(),
                        sample.positions.size() * sizeof(float)),
            0);
  for (const char* name : {"speed.npy", "time.npy", "step.npy", "ids.npy"}) {
    EXPECT_EQ(members.count(name), 1u) << name;
  }
}

TEST(NpzWriterTest, NumpyLoadsTheArrays) {
  TempDir dir;
  const fs::path path = dir.path() / "sample.npz";
  Sample().Write(path);
  const fs::path script = dir.path() / "check.py";
  std::ofstream(script) << R"(import sys, zipfile
import numpy as np
path = sys.argv[1]
assert zipfile.ZipFile(path).testzip() is None  # every member's CRC
d = np.load(path)
assert sorted(d.files) == ['ids', 'positions', 'speed', 'step', 'time'], d.files
F, N = 3, 5
f = np.arange(F)[:, None]
n = np.arange(N)[None, :]
p = d['positions']
assert p.dtype == np.float32 and p.shape == (F, N, 3), (p.dtype, p.shape)
expected = (f * 100 + n)[:, :, None] + np.arange(3)[None, None, :] / 4
assert np.array_equal(p, expected.astype(np.float32))
s = d['speed']
assert s.dtype == np.float32 and s.shape == (F, N)
assert np.array_equal(s, (f + n / 8).astype(np.float32))
t = d['time']
assert t.dtype == np.float64 and t.shape == (F,) and np.array_equal(t, np.arange(F) / 60)
st = d['step']
assert st.dtype == np.uint64 and np.array_equal(st, 3 * np.arange(F, dtype=np.uint64) + 2**40)
ids = d['ids']
assert ids.dtype == np.uint32 and np.array_equal(ids, 2 * np.arange(N))
print('numpy ok')
)";
  const fs::path log = dir.path() / "python.txt";
  const std::string command = "/usr/bin/python3 '" + script.string() + "' '" + path.string() +
                              "' >'" + log.string() + "' 2>&1";
  const int status = std::system(command.c_str());
  ASSERT_TRUE(status != -1 && WIFEXITED(status)) << command;
  EXPECT_EQ(WEXITSTATUS(status), 0) << ReadFile(log);
  EXPECT_THAT(ReadFile(log), HasSubstr("numpy ok"));
}

TEST(NpzWriterTest, ShapeMismatchAndUnwritablePathThrow) {
  TempDir dir;
  NpzWriter npz(dir.path() / "bad.npz");
  const std::vector<float> values(6);
  try {
    npz.Add("positions", std::span<const float>(values), {4, 3});
    ADD_FAILURE() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("positions"));
  }
  EXPECT_THROW(NpzWriter(dir.path() / "no_such_dir" / "x.npz"), std::runtime_error);
}

TEST(NpzWriterTest, AnEmptyArchiveIsValid) {
  TempDir dir;
  const fs::path path = dir.path() / "empty.npz";
  { NpzWriter npz(path); }  // closed by the destructor
  const std::string zip = ReadFile(path);
  ASSERT_EQ(zip.size(), 22u);
  EXPECT_EQ(Get32(zip, 0), 0x06054b50u);
}

}  // namespace
}  // namespace dysa
