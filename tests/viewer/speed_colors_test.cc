// Tests of viewer/src/speed_colors.cc: the thesis's gradient from slow blue to fast red.
#include "speed_colors.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace dysa::viewer {
namespace {

TEST(SpeedColorsTest, SlowIsBlueAndFastIsRed) {
  const Rgb slow = SpeedColor(0);
  EXPECT_GT(slow[2], slow[0] + 0.3f);
  EXPECT_GT(slow[2], slow[1]);
  const Rgb fast = SpeedColor(1);
  EXPECT_GT(fast[0], fast[2] + 0.5f);
  EXPECT_GT(fast[0], fast[1] + 0.5f);
}

// Hue in degrees (0 red, 120 green, 240 blue).
float Hue(const Rgb& c) {
  const float hue = std::atan2(std::sqrt(3.0f) * (c[1] - c[2]), 2 * c[0] - c[1] - c[2]);
  const float degrees = hue * 180.0f / 3.14159265f;
  return degrees < 0 ? degrees + 360 : degrees;
}

TEST(SpeedColorsTest, HueRunsFromBlueThroughGreenToRed) {
  EXPECT_NEAR(Hue(SpeedColor(0)), 225, 20);
  EXPECT_NEAR(Hue(SpeedColor(1)), 0, 10);
  float previous = 360;
  for (int i = 0; i <= 100; ++i) {
    const Rgb c = SpeedColor(i / 100.0f);
    for (float v : c) {
      EXPECT_GE(v, 0);
      EXPECT_LE(v, 1);
    }
    const float hue = Hue(c);
    EXPECT_LE(hue, previous + 1e-3f) << "t = " << i / 100.0f;  // never back towards blue
    previous = hue;
  }
}

TEST(SpeedColorsTest, IsContinuous) {
  for (int i = 0; i < 1000; ++i) {
    const Rgb a = SpeedColor(i / 1000.0f);
    const Rgb b = SpeedColor((i + 1) / 1000.0f);
    for (int c = 0; c < 3; ++c) EXPECT_LT(std::abs(a[c] - b[c]), 0.01f) << i;
  }
}

TEST(SpeedColorsTest, ClampsOutOfRangeAndNaN) {
  EXPECT_EQ(SpeedColor(-3), SpeedColor(0));
  EXPECT_EQ(SpeedColor(7), SpeedColor(1));
  EXPECT_EQ(SpeedColor(std::numeric_limits<float>::quiet_NaN()), SpeedColor(0));
}

TEST(SpeedColorsTest, TableSamplesTheGradientAsBytes) {
  const std::vector<unsigned char> table = SpeedColorTable(256);
  ASSERT_EQ(table.size(), 256u * 3);
  for (int i : {0, 100, 255}) {
    const Rgb c = SpeedColor(i / 255.0f);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(table[3 * i + k], c[k] * 255, 0.5) << i;
  }
}

TEST(SpeedColorsTest, SpeedToUnitMapsTheRangeAndClamps) {
  EXPECT_FLOAT_EQ(SpeedToUnit(2, 0, 4), 0.5f);
  EXPECT_FLOAT_EQ(SpeedToUnit(-1, 0, 4), 0);
  EXPECT_FLOAT_EQ(SpeedToUnit(9, 0, 4), 1);
  EXPECT_FLOAT_EQ(SpeedToUnit(3, 2, 2), 0);  // empty range
  EXPECT_FLOAT_EQ(SpeedToUnit(std::numeric_limits<float>::quiet_NaN(), 0, 1), 0);
}

}  // namespace
}  // namespace dysa::viewer
