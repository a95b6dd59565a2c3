#include "vtk_writer.h"

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace dysa {
namespace {

static_assert(sizeof(Real) == 4, "the VTK arrays below are declared Float32");

struct Array {
  std::string xml_head;  // <DataArray ...> attributes before offset
  std::vector<char> bytes;
};

template <class T>
std::vector<char> Bytes(const std::vector<T>& values) {
  std::vector<char> out(values.size() * sizeof(T));
  if (!out.empty()) std::memcpy(out.data(), values.data(), out.size());
  return out;
}

std::vector<char> Vec3Bytes(const std::vector<Vec3>& values) {
  std::vector<char> out(values.size() * 3 * sizeof(Real));
  for (size_t i = 0; i < values.size(); ++i) {
    std::memcpy(out.data() + i * 3 * sizeof(Real), values[i].data(), 3 * sizeof(Real));
  }
  return out;
}

}  // namespace

void WriteVtp(const std::filesystem::path& path, const ParticleArrays& p) {
  const size_t n = p.size();
  std::vector<Real> speed(n);
  for (size_t i = 0; i < n; ++i) speed[i] = p.velocity[i].norm();
  std::vector<int32_t> connectivity(n);
  std::vector<int32_t> offsets(n);
  for (size_t i = 0; i < n; ++i) connectivity[i] = int32_t(i), offsets[i] = int32_t(i + 1);

  // Sections in the order they appear in the XML; each appended block is a UInt64 byte count
  // followed by the bytes.
  const std::vector<std::pair<std::string, std::vector<char>>> arrays = {
      {R"(type="UInt32" Name="id")", Bytes(p.id)},
      {R"(type="Float32" Name="velocity" NumberOfComponents="3")", Vec3Bytes(p.velocity)},
      {R"(type="Float32" Name="speed")", Bytes(speed)},
      {R"(type="Float32" Name="density")", Bytes(p.density)},
      {R"(type="Float32" Name="pressure")", Bytes(p.pressure)},
      {R"(type="Float32" Name="position" NumberOfComponents="3")", Vec3Bytes(p.position)},
      {R"(type="Int32" Name="connectivity")", Bytes(connectivity)},
      {R"(type="Int32" Name="offsets")", Bytes(offsets)},
  };
  std::vector<uint64_t> offset(arrays.size());
  uint64_t at = 0;
  for (size_t k = 0; k < arrays.size(); ++k) {
    offset[k] = at;
    at += sizeof(uint64_t) + arrays[k].second.size();
  }
  auto tag = [&](size_t k) {
    return "        <DataArray " + arrays[k].first + R"( format="appended" offset=")" +
           std::to_string(offset[k]) + "\"/>\n";
  };

  std::ostringstream xml;
  xml << "<?xml version=\"1.0\"?>\n"
      << R"(<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian" header_type="UInt64">)"
      << "\n  <PolyData>\n"
      << "    <Piece NumberOfPoints=\"" << n << "\" NumberOfVerts=\"" << n
      << R"(" NumberOfLines="0" NumberOfStrips="0" NumberOfPolys="0">)"
      << "\n"
      << "      <PointData Scalars=\"speed\" Vectors=\"velocity\">\n"
      << tag(0) << tag(1) << tag(2) << tag(3) << tag(4) << "      </PointData>\n"
      << "      <Points>\n"
      << tag(5) << "      </Points>\n"
      << "      <Verts>\n"
      << tag(6) << tag(7) << "      </Verts>\n"
      << "    </Piece>\n  </PolyData>\n  <AppendedData encoding=\"raw\">\n   _";

  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  if (!file) throw std::runtime_error("cannot write " + path.string());
  const std::string head = xml.str();
  file.write(head.data(), std::streamsize(head.size()));
  for (const auto& [attributes, bytes] : arrays) {
    const uint64_t size = bytes.size();
    file.write(reinterpret_cast<const char*>(&size), sizeof(size));
    file.write(bytes.data(), std::streamsize(bytes.size()));
  }
  file << "\n  </AppendedData>\n</VTKFile>\n";
  if (!file) throw std::runtime_error("error writing " + path.string());
}

VtkSeriesWriter::VtkSeriesWriter(std::filesystem::path dir, std::string name)
    : dir_(std::move(dir)), name_(std::move(name)) {
  std::filesystem::create_directories(dir_ / name_);
}

void VtkSeriesWriter::WriteFrame(const ParticleArrays& particles, double time) {
  char file_name[32];
  std::snprintf(file_name, sizeof(file_name), "frame_%06zu.vtp", entries_.size());
  const std::string relative = name_ + "/" + file_name;
  WriteVtp(dir_ / relative, particles);
  entries_.emplace_back(time, relative);

  const std::filesystem::path pvd = dir_ / (name_ + ".pvd");
  std::ofstream out(pvd, std::ios::trunc);
  out.precision(9);
  out << "<?xml version=\"1.0\"?>\n"
      << R"(<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">)"
      << "\n"
      << "  <Collection>\n";
  for (const auto& [t, file] : entries_) {
    out << "    <DataSet timestep=\"" << t << R"(" group="" part="0" file=")" << file << "\"/>\n";
  }
  out << "  </Collection>\n</VTKFile>\n";
  if (!out) throw std::runtime_error("error writing " + pvd.string());
}

}  // namespace dysa
