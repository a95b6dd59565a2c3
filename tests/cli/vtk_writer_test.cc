// Tests of clients/cli/vtk_writer.h: a .vtp file read back byte for byte (XML head, then the
// appended raw blocks), and the .pvd collection of a series.
#include "vtk_writer.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "support/temp_dir.h"

namespace dysa {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

using dysa::testing::ReadFile;

// Each test gets its own directory.
struct TempDir : dysa::testing::TempDir {
  TempDir() : dysa::testing::TempDir("dysa_vtk") {}
};

// One DataArray of a .vtp file: its attributes and its bytes from the appended block.
struct DataArray {
  std::string type;
  int components = 1;
  std::vector<char> bytes;
};

// The parts of a .vtp file the tests check.
struct VtpFile {
  uint64_t points = 0;
  uint64_t verts = 0;
  std::map<std::string, DataArray> arrays;  // by Name
  std::string tail;                         // after the last appended block
};

std::string Attribute(const std::string& tag, const std::string& name) {
  const std::string key = " " + name + "=\"";
  const size_t at = tag.find(key);
  const size_t end = at == std::string::npos ? at : tag.find('"', at + key.size());
  if (end == std::string::npos) {
    ADD_FAILURE() << "no attribute " << name << " in " << tag;
    return "";
  }
  return tag.substr(at + key.size(), end - at - key.size());
}

// Every element "<NAME ...>" in `text`, in order.
std::vector<std::string> Tags(const std::string& text, const std::string& name) {
  std::vector<std::string> tags;
  const std::string open = "<" + name + " ";
  for (size_t at = text.find(open); at != std::string::npos; at = text.find(open, at + 1)) {
    const size_t end = text.find('>', at);
    if (end == std::string::npos) break;
    tags.push_back(text.substr(at, end + 1 - at));
  }
  return tags;
}

// Parses the XML head for NumberOfPoints and the DataArray offsets, then reads each appended
// raw block (a UInt64 byte count, then the data) at base + offset, base being the byte after
// the '_' that starts the appended data.
VtpFile ReadVtp(const fs::path& path) {
  VtpFile vtp;
  const std::string text = ReadFile(path);
  const size_t appended = text.find("<AppendedData encoding=\"raw\">");
  if (appended == std::string::npos) {
    ADD_FAILURE() << "no raw AppendedData in " << path;
    return vtp;
  }
  const size_t marker = text.find('_', appended);
  if (marker == std::string::npos) {
    ADD_FAILURE() << "no '_' marker in " << path;
    return vtp;
  }
  const std::string head = text.substr(0, appended);
  EXPECT_THAT(head, HasSubstr("<VTKFile type=\"PolyData\""));
  EXPECT_THAT(head, HasSubstr("byte_order=\"LittleEndian\""));
  EXPECT_THAT(head, HasSubstr("header_type=\"UInt64\""));
  const size_t piece = head.find("<Piece ");
  if (piece == std::string::npos) {
    ADD_FAILURE() << "no Piece in " << path;
    return vtp;
  }
  const std::string piece_tag = head.substr(piece, head.find('>', piece) - piece);
  vtp.points = std::stoull(Attribute(piece_tag, "NumberOfPoints"));
  vtp.verts = std::stoull(Attribute(piece_tag, "NumberOfVerts"));

  const size_t base = marker + 1;
  size_t end_of_blocks = base;
  for (const std::string& tag : Tags(head, "DataArray")) {
    EXPECT_EQ(Attribute(tag, "format"), "appended") << tag;
    DataArray array;
    array.type = Attribute(tag, "type");
    if (tag.find("NumberOfComponents") != std::string::npos) {
      array.components = std::stoi(Attribute(tag, "NumberOfComponents"));
    }
    const size_t at = base + std::stoull(Attribute(tag, "offset"));
    if (at + sizeof(uint64_t) > text.size()) {
      ADD_FAILURE() << "offset past the end of the file: " << tag;
      continue;
    }
    uint64_t size = 0;
    std::memcpy(&size, text.data() + at, sizeof(size));
    if (at + sizeof(size) + size > text.size()) {
      ADD_FAILURE() << "block past the end of the file: " << tag;
      continue;
    }
    array.bytes.assign(text.begin() + long(at + sizeof(size)),
                       text.begin() + long(at + sizeof(size) + size));
    end_of_blocks = std::max(end_of_blocks, at + sizeof(size) + size_t(size));
    const std::string name = Attribute(tag, "Name");
    EXPECT_EQ(vtp.arrays.count(name), 0u) << "duplicate array " << name;
    vtp.arrays[name] = std::move(array);
  }
  vtp.tail = text.substr(end_of_blocks);
  return vtp;
}

template <class T>
std::vector<T> Values(const DataArray& array) {
  EXPECT_EQ(array.bytes.size() % sizeof(T), 0u);
  std::vector<T> values(array.bytes.size() / sizeof(T));
  if (!values.empty()) std::memcpy(values.data(), array.bytes.data(), values.size() * sizeof(T));
  return values;
}

ParticleArrays SomeParticles() {
  ParticleArrays p;
  p.Resize(5);
  const std::vector<Vec3> positions = {Vec3(0, 0, 0), Vec3(1.5f, -2.25f, 3.125f),
                                       Vec3(1e-7f, 123456.78f, -0.1f), Vec3(-5, 5, -5),
                                       Vec3(0.3f, 0.7f, 0.9f)};
  for (size_t i = 0; i < p.size(); ++i) {
    p.id[i] = uint32_t(40 - 7 * i);  // ids in storage order, not 0..n-1
    p.position[i] = positions[i];
    p.velocity[i] = Vec3(Real(i), -2.0f * Real(i), 0.5f);
    p.density[i] = 600.0f + Real(i);
    p.pressure[i] = -3.5f * Real(i);
  }
  return p;
}

TEST(WriteVtpTest, PositionsIdsAndArraysRoundTripExactly) {
  TempDir dir;
  const ParticleArrays p = SomeParticles();
  const fs::path path = dir.path() / "particles.vtp";
  WriteVtp(path, p);
  const VtpFile vtp = ReadVtp(path);
  EXPECT_EQ(vtp.points, p.size());
  EXPECT_EQ(vtp.verts, p.size());
  for (const char* name :
       {"id", "velocity", "speed", "density", "pressure", "position", "connectivity", "offsets"}) {
    EXPECT_EQ(vtp.arrays.count(name), 1u) << name;
  }
  if (HasFailure()) return;

  const DataArray& position = vtp.arrays.at("position");
  EXPECT_EQ(position.type, "Float32");
  EXPECT_EQ(position.components, 3);
  const std::vector<float> xyz = Values<float>(position);
  ASSERT_EQ(xyz.size(), 3 * p.size());
  for (size_t i = 0; i < p.size(); ++i) {
    for (int a = 0; a < 3; ++a) EXPECT_EQ(xyz[3 * i + a], p.position[i][a]) << i << ", " << a;
  }

  const DataArray& id = vtp.arrays.at("id");
  EXPECT_EQ(id.type, "UInt32");
  EXPECT_EQ(Values<uint32_t>(id), p.id);

  const std::vector<float> v = Values<float>(vtp.arrays.at("velocity"));
  ASSERT_EQ(v.size(), 3 * p.size());
  const std::vector<float> speed = Values<float>(vtp.arrays.at("speed"));
  ASSERT_EQ(speed.size(), p.size());
  for (size_t i = 0; i < p.size(); ++i) {
    for (int a = 0; a < 3; ++a) EXPECT_EQ(v[3 * i + a], p.velocity[i][a]);
    EXPECT_FLOAT_EQ(speed[i], p.velocity[i].norm());
  }
  EXPECT_EQ(Values<float>(vtp.arrays.at("density")), p.density);
  EXPECT_EQ(Values<float>(vtp.arrays.at("pressure")), p.pressure);

  // One vertex cell per point: connectivity 0..n-1, offsets 1..n.
  const std::vector<int32_t> connectivity = Values<int32_t>(vtp.arrays.at("connectivity"));
  const std::vector<int32_t> offsets = Values<int32_t>(vtp.arrays.at("offsets"));
  ASSERT_EQ(connectivity.size(), p.size());
  ASSERT_EQ(offsets.size(), p.size());
  for (size_t i = 0; i < p.size(); ++i) {
    EXPECT_EQ(connectivity[i], int32_t(i));
    EXPECT_EQ(offsets[i], int32_t(i + 1));
  }
  // The XML closes after the last block.
  EXPECT_THAT(vtp.tail, HasSubstr("</AppendedData>"));
  EXPECT_THAT(vtp.tail, HasSubstr("</VTKFile>"));
}

TEST(WriteVtpTest, NoParticles) {
  TempDir dir;
  ParticleArrays p;
  const fs::path path = dir.path() / "empty.vtp";
  WriteVtp(path, p);
  const VtpFile vtp = ReadVtp(path);
  EXPECT_EQ(vtp.points, 0u);
  ASSERT_EQ(vtp.arrays.count("position"), 1u);
  EXPECT_TRUE(vtp.arrays.at("position").bytes.empty());
  EXPECT_THAT(vtp.tail, HasSubstr("</VTKFile>"));
}

TEST(WriteVtpTest, OverwritesAnExistingFile) {
  TempDir dir;
  const fs::path path = dir.path() / "again.vtp";
  WriteVtp(path, SomeParticles());
  ParticleArrays one;
  one.Resize(1);
  one.id[0] = 7;
  one.position[0] = Vec3(1, 2, 3);
  WriteVtp(path, one);
  const VtpFile vtp = ReadVtp(path);
  EXPECT_EQ(vtp.points, 1u);
  EXPECT_EQ(Values<uint32_t>(vtp.arrays.at("id")), std::vector<uint32_t>{7});
  EXPECT_EQ(Values<float>(vtp.arrays.at("position")), (std::vector<float>{1, 2, 3}));
}

TEST(WriteVtpTest, UnwritablePathThrowsNamingTheFile) {
  TempDir dir;
  const fs::path path = dir.path() / "no_such_dir" / "x.vtp";
  try {
    WriteVtp(path, SomeParticles());
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr(path.string()));
  }
}

TEST(WriteVtpTest, PointsWithOnlySomeArrays) {
  TempDir dir;
  VtpPoints points;
  points.positions = {1, 2, 3, -4, -5, -6};
  points.arrays.push_back({"id", "UInt32", 1, {}});
  const std::vector<uint32_t> ids = {0, 4};
  points.arrays.back().bytes.resize(sizeof(uint32_t) * ids.size());
  std::memcpy(points.arrays.back().bytes.data(), ids.data(), points.arrays.back().bytes.size());
  const fs::path path = dir.path() / "points.vtp";
  WriteVtp(path, points);
  const VtpFile vtp = ReadVtp(path);
  EXPECT_EQ(vtp.points, 2u);
  EXPECT_EQ(vtp.verts, 2u);
  EXPECT_EQ(vtp.arrays.size(), 4u);  // id, position, connectivity, offsets
  EXPECT_EQ(Values<uint32_t>(vtp.arrays.at("id")), ids);
  EXPECT_EQ(Values<float>(vtp.arrays.at("position")), points.positions);
  const std::string text = ReadFile(path);
  EXPECT_THAT(text, HasSubstr("<PointData>"));  // no Scalars or Vectors without those arrays
}

// The DataSet entries of a .pvd: (timestep, file) in order.
std::vector<std::pair<double, std::string>> ReadPvd(const fs::path& path) {
  const std::string text = ReadFile(path);
  EXPECT_THAT(text, HasSubstr("<VTKFile type=\"Collection\""));
  EXPECT_THAT(text, HasSubstr("</VTKFile>"));
  std::vector<std::pair<double, std::string>> entries;
  for (const std::string& tag : Tags(text, "DataSet")) {
    entries.emplace_back(std::stod(Attribute(tag, "timestep")), Attribute(tag, "file"));
  }
  return entries;
}

TEST(VtkSeriesWriterTest, WritesAPvdListingEveryFrameWithItsTime) {
  TempDir dir;
  VtkSeriesWriter writer(dir.path(), "frames");
  ParticleArrays p = SomeParticles();
  const std::vector<double> times = {0.0, 1.0 / 60, 2.0 / 60, 0.123456789};
  for (size_t f = 0; f < times.size(); ++f) {
    p.position[0] = Vec3(Real(f), 0, 0);  // mark each frame
    writer.WriteFrame(p, times[f]);
    EXPECT_EQ(writer.frames(), f + 1);
    // The collection is rewritten after every frame, so it always lists all frames so far.
    EXPECT_EQ(ReadPvd(dir.path() / "frames.pvd").size(), f + 1);
  }
  const auto entries = ReadPvd(dir.path() / "frames.pvd");
  ASSERT_EQ(entries.size(), times.size());
  std::set<std::string> files;
  for (size_t f = 0; f < times.size(); ++f) {
    EXPECT_NEAR(entries[f].first, times[f], 1e-9) << "frame " << f;
    const fs::path file = dir.path() / entries[f].second;  // relative to the .pvd
    ASSERT_TRUE(fs::exists(file)) << file;
    EXPECT_EQ(file.extension(), ".vtp");
    EXPECT_TRUE(files.insert(entries[f].second).second) << "file listed twice";
    const VtpFile vtp = ReadVtp(file);
    EXPECT_EQ(vtp.points, p.size());
    EXPECT_EQ(Values<float>(vtp.arrays.at("position"))[0], float(f)) << "frame " << f;
  }
  // Exactly the listed .vtp files exist.
  size_t vtp_files = 0;
  for (const auto& entry : fs::recursive_directory_iterator(dir.path())) {
    vtp_files += entry.path().extension() == ".vtp" ? 1 : 0;
  }
  EXPECT_EQ(vtp_files, times.size());
}

}  // namespace
}  // namespace dysa
