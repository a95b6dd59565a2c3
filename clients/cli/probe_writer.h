// OUT/probes.csv of `dysa run`, on one process or on ranks (run_distributed.h): a header of
// `time,step` and the probes' columns, then one row per call.
#pragma once

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <span>

#include "dysa/core/scene.h"

namespace dysa {

class ProbeWriter {
 public:
  // Throws std::runtime_error when `path` cannot be written.
  ProbeWriter(const std::filesystem::path& path, const Scene& scene);
  // One row: time (s), step and the probes' values in ProbeColumns() order.
  void Write(double time, uint64_t step, std::span<const double> values);

 private:
  std::ofstream file_;
};

}  // namespace dysa
