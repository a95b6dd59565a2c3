// ParaView output: one VTK XML PolyData file (.vtp) per frame and a .pvd collection indexing
// them by simulation time.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "dysa/core/state.h"

namespace dysa {

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
  size_t frames() const { return entries_.size(); }

 private:
  std::filesystem::path dir_;
  std::string name_;
  std::vector<std::pair<double, std::string>> entries_;  // time, file relative to dir_
};

}  // namespace dysa
