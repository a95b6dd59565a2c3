#include "view_error.h"

#include <stb/stb_image.h>
#include <stb/stb_image_write.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <map>
#include <stdexcept>

namespace dysa::bench {
namespace {

std::vector<double> Luminance(const Image& image) {
  std::vector<double> y(size_t(image.width) * size_t(image.height));
  for (size_t i = 0; i < y.size(); ++i) {
    const uint8_t* p = &image.rgb[3 * i];
    y[i] = 0.299 * p[0] + 0.587 * p[1] + 0.114 * p[2];
  }
  return y;
}

// Separable Gaussian blur (11 taps, sigma 1.5), "valid" region only: the result is
// (width - 10) x (height - 10), as in the reference SSIM implementation.
std::vector<double> Blur(const std::vector<double>& in, int width, int height) {
  constexpr int kRadius = 5;
  std::array<double, 2 * kRadius + 1> w{};
  double sum = 0;
  for (int k = -kRadius; k <= kRadius; ++k) sum += w[k + kRadius] = std::exp(-k * k / 4.5);
  for (double& v : w) v /= sum;
  const int ow = width - 2 * kRadius, oh = height - 2 * kRadius;
  std::vector<double> rows(size_t(ow) * size_t(height));
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < ow; ++x) {
      double s = 0;
      for (int k = 0; k <= 2 * kRadius; ++k) s += w[k] * in[size_t(y) * width + x + k];
      rows[size_t(y) * ow + x] = s;
    }
  }
  std::vector<double> out(size_t(ow) * size_t(oh));
  for (int y = 0; y < oh; ++y) {
    for (int x = 0; x < ow; ++x) {
      double s = 0;
      for (int k = 0; k <= 2 * kRadius; ++k) s += w[k] * rows[size_t(y + k) * ow + x];
      out[size_t(y) * ow + x] = s;
    }
  }
  return out;
}

std::vector<uint8_t> DrawnMask(const Image& image, std::array<uint8_t, 3> background) {
  std::vector<uint8_t> drawn(size_t(image.width) * size_t(image.height));
  for (size_t i = 0; i < drawn.size(); ++i) {
    int diff = 0;
    for (int c = 0; c < 3; ++c)
      diff = std::max(diff, std::abs(image.rgb[3 * i + c] - background[c]));
    drawn[i] = diff > 12;
  }
  return drawn;
}

std::array<uint8_t, 3> BorderMode(const Image& image) {
  std::map<std::array<uint8_t, 3>, int> counts;
  auto add = [&](int x, int y) {
    const uint8_t* p = &image.rgb[3 * (size_t(y) * image.width + x)];
    ++counts[{p[0], p[1], p[2]}];
  };
  for (int x = 0; x < image.width; ++x) add(x, 0), add(x, image.height - 1);
  for (int y = 0; y < image.height; ++y) add(0, y), add(image.width - 1, y);
  return std::max_element(counts.begin(), counts.end(),
                          [](const auto& a, const auto& b) { return a.second < b.second; })
      ->first;
}

// Squared Euclidean distance to the nearest set pixel of `seed`, exactly: the lower envelope
// of parabolas along rows, then along columns (Felzenszwalb and Huttenlocher 2012, "Distance
// Transforms of Sampled Functions").
void Envelope1d(const double* f, int n, size_t step, double* d, std::vector<int>& v,
                std::vector<double>& z) {
  int k = 0;
  v[0] = 0;
  z[0] = -std::numeric_limits<double>::infinity();
  z[1] = std::numeric_limits<double>::infinity();
  for (int q = 1; q < n; ++q) {
    double s = 0;
    while (true) {  // z[0] = -inf ends it
      const int p = v[k];
      s = ((f[q * step] + double(q) * q) - (f[p * step] + double(p) * p)) / (2.0 * (q - p));
      if (s > z[k]) break;
      --k;
    }
    ++k;
    v[k] = q;
    z[k] = s;
    z[k + 1] = std::numeric_limits<double>::infinity();
  }
  k = 0;
  for (int q = 0; q < n; ++q) {
    while (z[k + 1] < q) ++k;
    const double dq = q - v[k];
    d[q * step] = dq * dq + f[v[k] * step];
  }
}

std::vector<double> SquaredDistance(const std::vector<uint8_t>& seed, int width, int height) {
  const double far = 1e12;
  std::vector<double> f(seed.size()), d(seed.size());
  for (size_t i = 0; i < seed.size(); ++i) f[i] = seed[i] ? 0 : far;
  const int n = std::max(width, height);
  std::vector<int> v(n);
  std::vector<double> z(n + 1);
  for (int x = 0; x < width; ++x) Envelope1d(&f[x], height, width, &d[x], v, z);
  for (int y = 0; y < height; ++y) {
    Envelope1d(&d[size_t(y) * width], width, 1, &f[size_t(y) * width], v, z);
  }
  return f;
}

}  // namespace

Image ReadPng(const std::string& path) {
  Image image;
  int channels = 0;
  uint8_t* data = stbi_load(path.c_str(), &image.width, &image.height, &channels, 3);
  if (!data) throw std::runtime_error("cannot read PNG " + path + ": " + stbi_failure_reason());
  image.rgb.assign(data, data + size_t(image.width) * size_t(image.height) * 3);
  stbi_image_free(data);
  return image;
}

void WritePng(const std::string& path, const Image& image) {
  if (stbi_write_png(path.c_str(), image.width, image.height, 3, image.rgb.data(),
                     image.width * 3) == 0) {
    throw std::runtime_error("cannot write PNG " + path);
  }
}

ViewError CompareViews(const Image& reference, const Image& image) {
  if (reference.width != image.width || reference.height != image.height) {
    throw std::invalid_argument("images differ in size");
  }
  const int w = image.width, h = image.height;
  if (w < 11 || h < 11) throw std::invalid_argument("images smaller than the 11x11 SSIM window");
  ViewError e;

  // SSIM: local means, variances and covariance from Gaussian-weighted moments.
  const std::vector<double> a = Luminance(reference), b = Luminance(image);
  std::vector<double> aa(a.size()), bb(a.size()), ab(a.size());
  for (size_t i = 0; i < a.size(); ++i)
    aa[i] = a[i] * a[i], bb[i] = b[i] * b[i], ab[i] = a[i] * b[i];
  const std::vector<double> ma = Blur(a, w, h), mb = Blur(b, w, h), saa = Blur(aa, w, h),
                            sbb = Blur(bb, w, h), sab = Blur(ab, w, h);
  const double c1 = std::pow(0.01 * 255, 2), c2 = std::pow(0.03 * 255, 2);

  const auto background = BorderMode(reference);
  const std::vector<uint8_t> drawn_ref = DrawnMask(reference, background);
  const std::vector<uint8_t> drawn_img = DrawnMask(image, background);
  const int ow = w - 10, oh = h - 10;
  double sum = 0, sum_drawn = 0;
  int64_t n_drawn = 0;
  for (int y = 0; y < oh; ++y) {
    for (int x = 0; x < ow; ++x) {
      const size_t i = size_t(y) * ow + x;
      const double va = saa[i] - ma[i] * ma[i], vb = sbb[i] - mb[i] * mb[i],
                   cov = sab[i] - ma[i] * mb[i];
      const double s = ((2 * ma[i] * mb[i] + c1) * (2 * cov + c2)) /
                       ((ma[i] * ma[i] + mb[i] * mb[i] + c1) * (va + vb + c2));
      sum += s;
      const size_t centre = size_t(y + 5) * w + x + 5;
      if (drawn_ref[centre] || drawn_img[centre]) sum_drawn += s, ++n_drawn;
    }
  }
  e.ssim = sum / (double(ow) * oh);
  e.ssim_drawn = n_drawn > 0 ? sum_drawn / double(n_drawn) : 1.0;

  // The largest gap: twice the largest distance from a pixel the reference draws to the
  // nearest pixel the image draws.
  const std::vector<double> d2 = SquaredDistance(drawn_img, w, h);
  double largest = 0;
  for (size_t i = 0; i < d2.size(); ++i) {
    e.drawn_reference += drawn_ref[i];
    e.drawn_image += drawn_img[i];
    if (drawn_ref[i]) largest = std::max(largest, d2[i]);
  }
  e.largest_gap_px = 2 * std::sqrt(largest);
  if (w >= 44 && h >= 44) {
    e.ssim_drawn_coarse = CompareViews(Downsample(reference, 4), Downsample(image, 4)).ssim_drawn;
  }
  return e;
}

Image Downsample(const Image& image, int factor) {
  Image out;
  out.width = image.width / factor;
  out.height = image.height / factor;
  out.rgb.resize(size_t(out.width) * out.height * 3);
  const int n = factor * factor;
  for (int y = 0; y < out.height; ++y) {
    for (int x = 0; x < out.width; ++x) {
      for (int c = 0; c < 3; ++c) {
        int s = 0;
        for (int dy = 0; dy < factor; ++dy)
          for (int dx = 0; dx < factor; ++dx)
            s += image.rgb[3 * (size_t(factor * y + dy) * image.width + factor * x + dx) + c];
        out.rgb[3 * (size_t(y) * out.width + x) + c] = uint8_t((s + n / 2) / n);
      }
    }
  }
  return out;
}

Image ContactSheet(const std::vector<Image>& images, int columns) {
  if (images.empty() || columns < 1) throw std::invalid_argument("nothing to put on a sheet");
  const int tw = images[0].width / 2, th = images[0].height / 2;
  const int rows = int((images.size() + columns - 1) / columns);
  Image sheet;
  sheet.width = tw * std::min<int>(columns, int(images.size()));
  sheet.height = th * rows;
  sheet.rgb.assign(size_t(sheet.width) * sheet.height * 3, 255);
  for (size_t k = 0; k < images.size(); ++k) {
    const Image& im = images[k];
    if (im.width != images[0].width || im.height != images[0].height) {
      throw std::invalid_argument("images on a sheet differ in size");
    }
    const int ox = int(k % columns) * tw, oy = int(k / columns) * th;
    for (int y = 0; y < th; ++y) {
      for (int x = 0; x < tw; ++x) {
        for (int c = 0; c < 3; ++c) {
          int s = 0;
          for (int dy = 0; dy < 2; ++dy)
            for (int dx = 0; dx < 2; ++dx)
              s += im.rgb[3 * (size_t(2 * y + dy) * im.width + 2 * x + dx) + c];
          sheet.rgb[3 * (size_t(oy + y) * sheet.width + ox + x) + c] = uint8_t((s + 2) / 4);
        }
      }
    }
  }
  return sheet;
}

}  // namespace dysa::bench
