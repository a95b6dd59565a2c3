// SPHERIC Test 2 (dysa/core/validation_impact.h) at the quick resolution.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "dysa/core/validation_impact.h"

namespace dysa {
namespace {

constexpr double kQuickSpacing = 0.05;

TEST(SphericTest2Test, Explore) {
  ValidationOptions options;
  if (const char* device = std::getenv("SPHERIC_DEVICE")) options.device = ParseDevice(device);
  options.spacing = std::getenv("SPHERIC_D") ? std::atof(std::getenv("SPHERIC_D")) : kQuickSpacing;
  const SphericTest2Result r = RunSphericTest2(
      options, std::getenv("SPHERIC_END") ? std::atof(std::getenv("SPHERIC_END")) : 0.5);
  std::printf("particles %zu steps %llu\n", r.run.particles, (unsigned long long)r.run.steps);
  std::printf("arrival %g peak %g at %g h4 %g errs %g %g %g %g\n", r.p1_arrival.value_or(-1),
              r.p1_peak, r.p1_peak_time, r.h4_error_first_second, r.height_error[0],
              r.height_error[1], r.height_error[2], r.height_error[3]);
  if (const char* dump = std::getenv("SPHERIC_DUMP")) {
    std::FILE* f = std::fopen(dump, "w");
    for (size_t k = 0; k < r.times.size(); ++k) {
      std::fprintf(f, "%.6f", r.times[k]);
      for (int s = 0; s < 8; ++s) std::fprintf(f, ",%.1f", r.pressure[s][k]);
      for (int g = 0; g < 4; ++g) std::fprintf(f, ",%.4f", r.height[g][k]);
      std::fprintf(f, "\n");
    }
    std::fclose(f);
  }
  for (size_t k = 0; k < r.times.size(); k += 40) {
    std::printf("%.4f P1 %.0f/%.0f P2 %.0f P5 %.0f H2 %.3f H3 %.3f H4 %.3f\n", r.times[k],
                r.pressure[0][k], r.pressure_filtered[0][k], r.pressure_filtered[1][k],
                r.pressure_filtered[4][k], r.height[1][k], r.height[2][k], r.height[3][k]);
  }
}

}  // namespace
}  // namespace dysa
