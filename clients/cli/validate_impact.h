// `dysa validate`'s report of SPHERIC Test 2 (dysa/validation/validation_impact.h): the run, P1's
// arrival and peak beside the published ones, and every sensor and gauge over the run beside
// the MARIN heights.
#pragma once

#include <string>

#include "dysa/validation/validation_impact.h"

namespace dysa {

// The quick resolution of `dysa validate --quick` and tests/validation/spheric_test2_test.cc:
// 11 particle layers of water, 25 x 11 x 20 = 5,500 particles.
inline constexpr double kQuickSphericSpacing = 0.05;

// What the run measured beside the published values, a line each (after RunText's line).
std::string SphericDiagnosticsText(const SphericTest2Result& r);
// P1-P8 (filtered, kPa) and H1-H4 (m, beside MARIN's) every `interval` seconds.
std::string SphericSeriesText(const SphericTest2Result& r, double interval = 0.05);

}  // namespace dysa
