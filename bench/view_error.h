// Image error of a reduced-detail rendering against the full-detail one (remote_view_bench):
// SSIM over the luminance and the largest screen gap between drawn particles.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace dysa::bench {

struct Image {
  int width = 0;
  int height = 0;
  std::vector<uint8_t> rgb;  // 3 bytes per pixel, rows top to bottom
};

// Throws std::runtime_error naming the file when it cannot be read.
Image ReadPng(const std::string& path);
void WritePng(const std::string& path, const Image& image);

struct ViewError {
  // Mean SSIM (Wang, Bovik, Sheikh and Simoncelli 2004: 11x11 Gaussian window, sigma 1.5,
  // K1 = 0.01, K2 = 0.03) of the luminance (BT.601 weights) over the whole frame...
  double ssim = 0;
  // ...and over the pixels either image draws something on (the background, which matches
  // trivially, left out): the stricter figure.
  double ssim_drawn = 0;
  // ssim_drawn of both images averaged over 4x4 pixel blocks: the shape and colour of the fluid
  // rather than each sphere's highlight (a coarse scale of multi-scale SSIM, Wang, Simoncelli and
  // Bovik 2003). At full resolution a subset's spheres never fall where the full set's do.
  double ssim_drawn_coarse = 0;
  // Pixels, the diameter of the largest disc inside the full-detail image's drawn region that
  // holds no drawn pixel of the reduced image: the largest hole a budget opens in the fluid.
  double largest_gap_px = 0;
  // Drawn pixels of each image.
  int64_t drawn_reference = 0;
  int64_t drawn_image = 0;
};

// `reference` and `image` must have the same size (std::invalid_argument otherwise). The
// background is the most common colour of the reference's border; a pixel is drawn when a
// channel differs from it by more than 12 of 255.
ViewError CompareViews(const Image& reference, const Image& image);

// The image averaged over `factor` x `factor` pixel blocks (the remainder cropped).
Image Downsample(const Image& image, int factor);

// The images side by side, `columns` per row, each halved in size (2x2 box filter): a contact
// sheet of a budget sweep. Every image must have the size of the first.
Image ContactSheet(const std::vector<Image>& images, int columns);

}  // namespace dysa::bench
