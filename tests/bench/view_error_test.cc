// The image error remote_view_bench reports (bench/view_error.h): SSIM of identical images is 1
// and falls with a change, the largest gap is the diameter of the largest hole, and the drawn
// region ignores the background.
#include "view_error.h"

#include <gtest/gtest.h>

#include <cmath>

namespace dysa::bench {
namespace {

constexpr uint8_t kBackground[3] = {30, 32, 36};

Image Blank(int w, int h) {
  Image im{w, h, std::vector<uint8_t>(size_t(w) * h * 3)};
  for (size_t i = 0; i < size_t(w) * h; ++i) {
    for (int c = 0; c < 3; ++c) im.rgb[3 * i + c] = kBackground[c];
  }
  return im;
}

void Fill(Image& im, int x0, int y0, int x1, int y1, uint8_t value) {
  for (int y = y0; y < y1; ++y) {
    for (int x = x0; x < x1; ++x) {
      for (int c = 0; c < 3; ++c) im.rgb[3 * (size_t(y) * im.width + x) + c] = value;
    }
  }
}

TEST(ViewError, IdenticalImagesScoreOneWithNoGap) {
  Image a = Blank(120, 80);
  Fill(a, 30, 20, 90, 60, 200);
  const ViewError e = CompareViews(a, a);
  EXPECT_DOUBLE_EQ(e.ssim, 1.0);
  EXPECT_DOUBLE_EQ(e.ssim_drawn, 1.0);
  EXPECT_DOUBLE_EQ(e.largest_gap_px, 0.0);
  EXPECT_EQ(e.drawn_reference, 60 * 40);
  EXPECT_EQ(e.drawn_image, 60 * 40);
}

TEST(ViewError, AHoleIsMeasuredByItsDiameterAndLowersSsim) {
  Image full = Blank(120, 80);
  Fill(full, 30, 20, 90, 60, 200);
  Image holed = full;
  Fill(holed, 50, 30, 71, 51, kBackground[0]);  // a 21 x 21 hole, background again
  for (int y = 30; y < 51; ++y) {               // the background's exact colour in every channel
    for (int x = 50; x < 71; ++x) {
      for (int c = 0; c < 3; ++c) holed.rgb[3 * (size_t(y) * 120 + x) + c] = kBackground[c];
    }
  }
  const ViewError e = CompareViews(full, holed);
  // The hole's centre is 11 px from the nearest drawn pixel: a gap of 22 px (the drawn pixels
  // around it sit just outside).
  EXPECT_NEAR(e.largest_gap_px, 22.0, 1e-9);
  EXPECT_LT(e.ssim, 1.0);
  EXPECT_LT(e.ssim_drawn, e.ssim) << "the background, which matches, is left out";
  EXPECT_EQ(e.drawn_image, 60 * 40 - 21 * 21);
}

TEST(ViewError, ImagesOfDifferentSizesAreRefused) {
  EXPECT_THROW(CompareViews(Blank(40, 40), Blank(40, 41)), std::invalid_argument);
}

TEST(ViewError, DownsampleAveragesBlocks) {
  Image a = Blank(8, 4);
  Fill(a, 0, 0, 2, 2, 100);
  Fill(a, 2, 0, 4, 2, 0);
  const Image d = Downsample(a, 2);
  ASSERT_EQ(d.width, 4);
  ASSERT_EQ(d.height, 2);
  EXPECT_EQ(d.rgb[0], 100);
  EXPECT_EQ(d.rgb[3], 0);
  EXPECT_EQ(d.rgb[3 * 4], kBackground[0]);
}

}  // namespace
}  // namespace dysa::bench
