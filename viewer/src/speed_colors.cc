#include "speed_colors.h"

#include <algorithm>
#include <cmath>

namespace dysa::viewer {

namespace {

struct Stop {
  float t;
  Rgb color;
};

constexpr std::array<Stop, 5> kStops = {{
    {0.00f, {0.05f, 0.20f, 0.60f}},  // deep blue: at rest
    {0.30f, {0.10f, 0.55f, 0.90f}},  // light blue
    {0.55f, {0.30f, 0.85f, 0.55f}},  // green
    {0.78f, {0.98f, 0.85f, 0.20f}},  // yellow
    {1.00f, {0.90f, 0.15f, 0.10f}},  // red: fastest
}};

}  // namespace

Rgb SpeedColor(float t) {
  if (!(t > 0)) return kStops.front().color;  // also NaN
  if (t >= 1) return kStops.back().color;
  size_t i = 1;
  while (kStops[i].t < t) ++i;
  const Stop& a = kStops[i - 1];
  const Stop& b = kStops[i];
  const float s = (t - a.t) / (b.t - a.t);
  Rgb out;
  for (int c = 0; c < 3; ++c) out[c] = a.color[c] + s * (b.color[c] - a.color[c]);
  return out;
}

std::vector<unsigned char> SpeedColorTable(int texels) {
  std::vector<unsigned char> bytes;
  if (texels < 2) texels = 2;
  bytes.reserve(size_t(texels) * 3);
  for (int i = 0; i < texels; ++i) {
    const Rgb c = SpeedColor(float(i) / float(texels - 1));
    for (float v : c) bytes.push_back(static_cast<unsigned char>(std::lround(v * 255.0f)));
  }
  return bytes;
}

float SpeedToUnit(float speed, float lo, float hi) {
  if (!(hi > lo)) return 0;
  const float t = (speed - lo) / (hi - lo);
  if (!(t > 0)) return 0;
  return t < 1 ? t : 1;
}

}  // namespace dysa::viewer
