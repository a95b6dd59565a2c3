// The drawn radius of a budgeted stream's particles (viewer/src/detail_scale.h): volume
// scaling, so a subset fills the fluid's volume as the full set did.
#include "detail_scale.h"

#include <gtest/gtest.h>

#include <cmath>

namespace dysa::viewer {
namespace {

TEST(DetailScaleTest, WholeFramesAreDrawnAsTheyAre) {
  EXPECT_EQ(DetailRadiusScale(1.0), 1.0f);
  EXPECT_EQ(DetailRadiusScale(0.0), 1.0f);  // no detail known: as is
  EXPECT_EQ(DetailRadiusScale(NAN), 1.0f);
}

TEST(DetailScaleTest, KeepsTheVolumeFilled) {
  for (double f : {0.5, 0.125, 1.0 / 64}) {
    const double r = DetailRadiusScale(f);
    // f particles of volume r^3 fill what the whole set of unit volume did.
    EXPECT_NEAR(f * r * r * r, 1.0, 1e-5) << f;
  }
  EXPECT_NEAR(DetailRadiusScale(1.0 / 64), 4.0f, 1e-5);  // not 8 (area scaling)
  EXPECT_NEAR(DetailRadiusScale(1e-9), 16.0f, 1e-4);     // bounded at 1/4096
}

}  // namespace
}  // namespace dysa::viewer
