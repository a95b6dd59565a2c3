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

void WriteVtp(const std::filesystem::path& path, const VtpPoints& points) {
  const size_t n = points.positions.size() / 3;
  std::vector<int32_t> connectivity(n);
  std::vector<int32_t> offsets(n);
  for (size_t i = 0; i < n; ++i) connectivity[i] = int32_t(i), offsets[i] = int32_t(i + 1);

  // Sections in the order they appear in the XML: the point arrays, then the points and the
  // vertex cells; each appended block is a UInt64 byte count followed by the bytes.
  std::vector<std::pair<std::string, const std::vector<char>*>> arrays;
  for (const VtpArray& a : points.arrays) {
    std::string attributes = "type=\"" + a.type + "\" Name=\"" + a.name + "\"";
    if (a.components != 1) {
      attributes += " NumberOfComponents=\"" + std::to_string(a.components) + "\"";
    }
    arrays.emplace_back(std::move(attributes), &a.bytes);
  }
  const size_t point_arrays = arrays.size();
  const std::vector<char> position_bytes = Bytes(points.positions);
  const std::vector<char> connectivity_bytes = Bytes(connectivity);
  const std::vector<char> offset_bytes = Bytes(offsets);
  arrays.emplace_back(R"(type="Float32" Name="position" NumberOfComponents="3")", &position_bytes);
  arrays.emplace_back(R"(type="Int32" Name="connectivity")", &connectivity_bytes);
  arrays.emplace_back(R"(type="Int32" Name="offsets")", &offset_bytes);

  std::vector<uint64_t> offset(arrays.size());
  uint64_t at = 0;
  for (size_t k = 0; k < arrays.size(); ++k) {
    offset[k] = at;
    at += sizeof(uint64_t) + arrays[k].second->size();
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
      << "      <PointData";
  if (!points.scalars.empty()) xml << " Scalars=\"" << points.scalars << "\"";
  if (!points.vectors.empty()) xml << " Vectors=\"" << points.vectors << "\"";
  xml << ">\n";
  for (size_t k = 0; k < point_arrays; ++k) xml << tag(k);
  xml << "      </PointData>\n"
      << "      <Points>\n"
      << tag(point_arrays) << "      </Points>\n"
      << "      <Verts>\n"
      << tag(point_arrays + 1) << tag(point_arrays + 2) << "      </Verts>\n"
      << "    </Piece>\n  </PolyData>\n  <AppendedData encoding=\"raw\">\n   _";

  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  if (!file) throw std::runtime_error("cannot write " + path.string());
  const std::string head = xml.str();
  file.write(head.data(), std::streamsize(head.size()));
  for (const auto& [attributes, bytes] : arrays) {
    const uint64_t size = bytes->size();
    file.write(reinterpret_cast<const char*>(&size), sizeof(size));
    file.write(bytes->data(), std::streamsize(bytes->size()));
  }
  file << "\n  </AppendedData>\n</VTKFile>\n";
  if (!file) throw std::runtime_error("error writing " + path.string());
}

void WriteVtp(const std::filesystem::path& path, const ParticleArrays& p) {
  const size_t n = p.size();
  std::vector<Real> speed(n);
  for (size_t i = 0; i < n; ++i) speed[i] = p.velocity[i].norm();
  VtpPoints points;
  const std::vector<char> position_bytes = Vec3Bytes(p.position);
  points.positions.resize(3 * n);
  if (n > 0) std::memcpy(points.positions.data(), position_bytes.data(), position_bytes.size());
  points.arrays = {
      {"id", "UInt32", 1, Bytes(p.id)},
      {"velocity", "Float32", 3, Vec3Bytes(p.velocity)},
      {"speed", "Float32", 1, Bytes(speed)},
      {"density", "Float32", 1, Bytes(p.density)},
      {"pressure", "Float32", 1, Bytes(p.pressure)},
  };
  points.scalars = "speed";
  points.vectors = "velocity";
  WriteVtp(path, points);
}

VtkSeriesWriter::VtkSeriesWriter(std::filesystem::path dir, std::string name)
    : dir_(std::move(dir)), name_(std::move(name)) {
  std::filesystem::create_directories(dir_ / name_);
}

std::string VtkSeriesWriter::NextFile() const {
  char file_name[32];
  std::snprintf(file_name, sizeof(file_name), "frame_%06zu.vtp", entries_.size());
  return name_ + "/" + file_name;
}

void VtkSeriesWriter::WriteFrame(const ParticleArrays& particles, double time) {
  std::string relative = NextFile();
  WriteVtp(dir_ / relative, particles);
  AddEntry(time, std::move(relative));
}

void VtkSeriesWriter::WriteFrame(const VtpPoints& points, double time) {
  std::string relative = NextFile();
  WriteVtp(dir_ / relative, points);
  AddEntry(time, std::move(relative));
}

void VtkSeriesWriter::AddEntry(double time, std::string relative) {
  entries_.emplace_back(time, std::move(relative));

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
