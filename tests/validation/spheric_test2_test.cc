// SPHERIC Test 2 (dysa/validation/validation_impact.h): the sensors' filter and a quick run (11
// particle layers of water, 5,500 particles) as far as P1's first impact; the reference data are
// reference_data_test.cc's. The
// bounds hold with margin at that resolution (measured values in the comments, from a run to
// 0.7 s) and fail for wrong physics: a wet sensor before the water can reach it, a front that
// runs too slow or too fast, an impact pressure of the wrong scale, a reservoir that drains at
// the wrong rate. The published peak (11 kPa) and arrival target (10 ms) are for the finer
// default resolution (`dysa validate`, docs/validation.md): at this one particle-scale impacts
// dominate the filtered peak, and no bound is put on it.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "dysa/validation/validation_impact.h"

namespace dysa {
namespace {

constexpr double kQuickSpacing = 0.05;  // validate_impact.h's kQuickSphericSpacing

TEST(SensorFilterTest, MovingAverageIsCentredAndWeightedByTheStepLength) {
  // A constant stays itself, whatever the steps.
  const std::vector<double> times = {0.001, 0.002, 0.004, 0.005, 0.006, 0.010, 0.011};
  const std::vector<double> constant(times.size(), 7.5);
  for (double v : MovingAverage(times, constant, 0.005)) EXPECT_DOUBLE_EQ(v, 7.5);
  // A pulse is spread around its own time, not after it: the centred window keeps it in place.
  std::vector<double> uniform_times, pulse;
  for (int k = 1; k <= 21; ++k) {
    uniform_times.push_back(0.001 * k);
    pulse.push_back(k == 11 ? 10.0 : 0.0);
  }
  const std::vector<double> spread = MovingAverage(uniform_times, pulse, 0.005);
  EXPECT_NEAR(spread[10], 2.0, 1e-12);  // five samples of 1 ms in (t - 2.5 ms, t + 2.5 ms]
  EXPECT_NEAR(spread[8], 2.0, 1e-12);
  EXPECT_NEAR(spread[12], 2.0, 1e-12);
  EXPECT_NEAR(spread[7], 0.0, 1e-12);
  EXPECT_NEAR(spread[13], 0.0, 1e-12);
  // Each sample counts by the length of the step that ended at it: a long step weighs more.
  const std::vector<double> t2 = {0.001, 0.004};  // steps of 1 and 3 ms
  const std::vector<double> v2 = {0.0, 4.0};
  EXPECT_DOUBLE_EQ(MovingAverage(t2, v2, 0.01)[0], 3.0);  // (0 * 1 + 4 * 3) / 4
}

TEST(SphericTest2Test, QuickRunReachesP1OnTimeWithTheImpactsScale) {
  ValidationOptions options;
  options.spacing = kQuickSpacing;
  // P1's arrival (0.42 s here) and the impact window after it: no further.
  const SphericTest2Result r = RunSphericTest2(options, kP1ArrivalMeasured + 0.04 + kImpactWindow);
  EXPECT_EQ(r.run.particles, 25u * 11 * 20);   // 1.25 x 0.55 x 1 m of whole spacings
  ASSERT_EQ(r.times.size(), r.run.steps + 1);  // the t = 0 sample and one after every step
  // The reservoir starts at the experiment's depth: its top particle half a spacing below it.
  EXPECT_NEAR(r.height[3].front(), kSphericDepth, 1e-6);

  // Every sensor is dry until the water can have reached the box (0.35 s after the release it
  // is at H2, 0.17 m before the box, in the experiment): 0 in every step to 0.3 s.
  for (size_t k = 0; k < r.times.size() && r.times[k] <= 0.3; ++k) {
    for (int s = 0; s < kSphericPressureSensors; ++s) {
      ASSERT_EQ(r.pressure[s][k], 0.0) << "P" << s + 1 << " at t = " << r.times[k];
    }
  }
  // The front passes H3 (x = 1.488 m, 0.5 m from the dam) at 0.19 s in the experiment; here at
  // 0.217 s (a coarse front is slower).
  double h3_wet = -1;
  for (size_t k = 0; k < r.times.size(); ++k) {
    if (r.height[2][k] > 0) {
      h3_wet = r.times[k];
      break;
    }
  }
  EXPECT_GT(h3_wet, 0.15);
  EXPECT_LT(h3_wet, 0.26);

  // P1 (first 1 ms value above 500 Pa): MARIN 0.393 s. P2, 4 cm higher on the face, wets after
  // it (MARIN 17 ms after).
  ASSERT_TRUE(r.p1_arrival.has_value());
  EXPECT_NEAR(*r.p1_arrival, kP1ArrivalMeasured, 0.040);
  ASSERT_TRUE(r.p2_arrival.has_value());
  EXPECT_GE(*r.p2_arrival, *r.p1_arrival);
  // The 5 ms average of the same impact is lower than its 1 ms peak (it spreads the spike).
  EXPECT_LT(r.p1_peak_5ms, r.p1_peak);
  EXPECT_GT(r.p1_peak_5ms, 0);
  // The impact's mean pressure over 0.1 s: measured 7.6 kPa. The stagnation pressure of a front
  // at 3-4 m/s is rho v^2 / 2 = 4.5-8 kPa; a pressure of the wrong scale (no gradient moment, a
  // missing hydrostatic correction, a wall that lets the water through) misses 2-20 kPa.
  EXPECT_GT(r.p1_impact_mean, 2000);
  EXPECT_LT(r.p1_impact_mean, 20000);
  EXPECT_GT(r.p1_peak, r.p1_impact_mean);

  // H4: measured 3.8% RMS over the run's 0.535 s (the reservoir drains a little slower than
  // the experiment's: 0.476 m against 0.454 m at 0.42 s). Target at the default resolution: 5%
  // over the first second.
  EXPECT_LT(r.h4_error_first_second, 0.06);
  // The box force F (the scene's box_force probe): read at most every 0.1 ms of simulated time,
  // 0 while the box is dry, then the impact's push towards -x. Its 1 ms peak, measured 2,510 N
  // at 0.428 s here, is the face's area (0.161 x 0.403 m) times a pressure of P1's 1 ms peak's
  // scale, spiky like it at this resolution (DualSPHysics's force gauge reads 766 N at dp 0.01,
  // ../shared/notes/spheric2.md); a force 10 times off in either direction is wrong physics.
  ASSERT_EQ(r.force_times.size(), r.force_x.size());
  ASSERT_GT(r.force_times.size(), 100u);
  for (size_t k = 1; k < r.force_times.size(); ++k) {
    ASSERT_GE(r.force_times[k] - r.force_times[k - 1], kBoxForceInterval - 1e-12) << k;
    if (r.force_times[k] <= 0.3) {
      ASSERT_EQ(r.force_x[k], 0.0) << "t = " << r.force_times[k];
    }
  }
  std::printf("box force: 1 ms peak %.1f N at %.4f s\n", r.force_peak, r.force_peak_time);
  EXPECT_GT(r.force_peak, 250);
  EXPECT_LT(r.force_peak, 25000);
  EXPECT_GT(r.force_peak_time, *r.p1_arrival - 0.01);
}

}  // namespace
}  // namespace dysa
