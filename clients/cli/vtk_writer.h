// ParaView output: one VTK XML PolyData file (.vtp) per frame and a .pvd collection indexing
// them by simulation time.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "dysa/core/state.h"

namespace dysa {

// One point array of a .vtp file: raw little-endian values of a VTK type ("Float32", "UInt32").
struct VtpArray {
  std::string name;
  std::string type;
  int components = 1;
  std::vector<char> bytes;
};

// A point set with any point arrays, for frames that do not come from a ParticleArrays (frames
// decoded from a stream carry only the fields a subscriber asked for).
struct VtpPoints {
  std::vector<float> positions;  // xyz per point, m
  std::vector<VtpArray> arrays;
  std::string scalars;  // the array ParaView colours by; "" for none
  std::string vectors;  // "" for none
};

// Writes the points with vertex cells (so ParaView draws them as they open) and the point
// arrays, in appended raw binary. Throws std::runtime_error naming the file on I/O failure.
void WriteVtp(const std::filesystem::path& path, const VtpPoints& points);

// Writes the particles as points with vertex cells (so ParaView draws them as they open) and
// the point arrays id, velocity, speed, density and pressure, in appended raw binary.
// Throws std::runtime_error naming the file on I/O failure.
void WriteVtp(const std::filesystem::path& path, const ParticleArrays& particles);

// Collects frames and rewrites DIR/NAME.pvd after each one, so a run cut short still leaves a
// series ParaView opens.
class VtkSeriesWriter {
 public:
  VtkSeriesWriter(std::filesystem::path dir, std::string name);
  void WriteFrame(const ParticleArrays& particles, double time);
  void WriteFrame(const VtpPoints& points, double time);
  size_t frames() const { return entries_.size(); }

 private:
  // The next frame's file, relative to dir_; AddEntry() then records it and rewrites the .pvd.
  std::string NextFile() const;
  void AddEntry(double time, std::string relative);

  std::filesystem::path dir_;
  std::string name_;
  std::vector<std::pair<double, std::string>> entries_;  // time, file relative to dir_
};

}  // namespace dysa
