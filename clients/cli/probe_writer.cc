#include "probe_writer.h"

#include <iomanip>
#include <stdexcept>
#include <string>

#include "dysa/core/probes.h"

namespace dysa {

ProbeWriter::ProbeWriter(const std::filesystem::path& path, const Scene& scene) : file_(path) {
  if (!file_) throw std::runtime_error("cannot write " + path.string());
  file_ << "time,step";
  for (const std::string& column : ProbeColumns(scene.probes)) file_ << ',' << column;
  file_ << '\n';
  file_ << std::setprecision(9);
}

void ProbeWriter::Write(double time, uint64_t step, std::span<const double> values) {
  file_ << time << ',' << step;
  for (double v : values) file_ << ',' << v;
  file_ << '\n';
  if (!file_) throw std::runtime_error("error writing probes.csv");
}

}  // namespace dysa
