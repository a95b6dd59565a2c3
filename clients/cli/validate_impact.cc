#include "validate_impact.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

namespace dysa {
namespace {

std::string Format(const char* format, auto... values) {
  char text[256];
  std::snprintf(text, sizeof text, format, values...);
  return text;
}

// The index of the last sample at or before t.
size_t SampleAt(const std::vector<double>& times, double t) {
  const auto it = std::upper_bound(times.begin(), times.end(), t + 1e-9);
  return it == times.begin() ? 0 : size_t(it - times.begin()) - 1;
}

}  // namespace

std::string SphericDiagnosticsText(const SphericTest2Result& r) {
  std::string s;
  if (r.p1_arrival) {
    s += Format("    P1 arrival (%.0f ms P1 > %.0f Pa) at %.4f s (MARIN %.3f s): %+.1f ms\n",
                1000 * kSensorWindow, kArrivalThreshold, *r.p1_arrival, kP1ArrivalMeasured,
                1000 * (*r.p1_arrival - kP1ArrivalMeasured));
    s += Format(
        "    P1 peak (%.0f ms, within %.1f s of the arrival) %.2f kPa at %.4f s (MARIN %.2f kPa "
        "at %.3f s): %+.0f%%; over %.0f ms %.2f kPa\n",
        1000 * kSensorWindow, kImpactWindow, r.p1_peak / 1000, r.p1_peak_time,
        kP1PeakMeasured / 1000, kP1PeakTimeMeasured, 100 * (r.p1_peak / kP1PeakMeasured - 1),
        1000 * kHistoryWindow, r.p1_peak_5ms / 1000);
    s += Format("    P1 mean over the %.1f s after the arrival: %.2f kPa\n", kImpactWindow,
                r.p1_impact_mean / 1000);
  } else {
    s += "    P1 stayed dry (1 ms P1 never above " + Format("%.0f", kArrivalThreshold) + " Pa)\n";
  }
  if (r.p2_arrival) {
    s += Format(
        "    P2 arrival %.4f s (MARIN %.3f s): %+.1f ms; peak %.2f kPa at %.4f s (MARIN %.2f "
        "kPa): %+.0f%%\n",
        *r.p2_arrival, kP2ArrivalMeasured, 1000 * (*r.p2_arrival - kP2ArrivalMeasured),
        r.p2_peak / 1000, r.p2_peak_time, kP2PeakMeasured / 1000,
        100 * (r.p2_peak / kP2PeakMeasured - 1));
  } else {
    s += "    P2 stayed dry\n";
  }
  s += Format(
      "    H4 RMS relative error over t <= 1 s: %.2f%%; RMS |H - H_ref| / %.2f m over "
      "the run: H1 %.2f%%, H2 %.2f%%, H3 %.2f%%, H4 %.2f%%\n",
      100 * r.h4_error_first_second, kSphericDepth, 100 * r.height_error[0],
      100 * r.height_error[1], 100 * r.height_error[2], 100 * r.height_error[3]);
  return s;
}

std::string SphericSeriesText(const SphericTest2Result& r, double interval) {
  std::string s =
      "\nspheric_test2: pressure (kPa, 1 ms average) and water height (m, simulated / MARIN)\n"
      "     t     P1     P2     P3     P4     P5     P6     P7     P8   H1 sim/ref     H2 sim/ref"
      "     H3 sim/ref     H4 sim/ref\n";
  if (r.times.empty()) return s;
  const std::vector<GaugeRow>& reference = MarinGaugeHeights();
  for (int k = 0;; ++k) {
    const double t = k * interval;
    if (t > r.times.back() + 1e-9) break;
    const size_t i = SampleAt(r.times, t);
    s += Format("%6.3f", t);
    for (int p = 0; p < kSphericPressureSensors; ++p) {
      // Not below 0 (a running sum's rounding can leave -1e-13 of a dry sensor's 0).
      s += Format(" %6.2f", std::max(0.0, r.pressure_filtered[p][i]) / 1000);
    }
    // The reference rows are 10 ms apart from t = 0.
    const size_t row = std::min(reference.size() - 1, size_t(std::lround(t / 0.01)));
    for (int g = 0; g < kSphericGauges; ++g) {
      s += Format("  %6.3f/%6.3f", r.height[g][i], reference[row].height[g]);
    }
    s += "\n";
  }
  return s;
}

}  // namespace dysa
