// The speed colour gradient: slow particles deep blue, then cyan, green and yellow, fast ones
// red, like the thesis's velocity gradient. Sampled into a 1D lookup texture once; the shaders
// map speed to [0, 1] with the user's adjustable range.
#pragma once

#include <array>
#include <vector>

namespace dysa::viewer {

using Rgb = std::array<float, 3>;  // linear 0..1

// The colour at t in [0, 1] (clamped): piecewise linear between the gradient's stops.
Rgb SpeedColor(float t);

// `texels` colours for t = i / (texels - 1), as RGB8 bytes (3 per texel).
std::vector<unsigned char> SpeedColorTable(int texels);

// Where a speed falls in the display range [lo, hi] (m/s), clamped to [0, 1]; an empty or
// inverted range maps everything to 0.
float SpeedToUnit(float speed, float lo, float hi);

}  // namespace dysa::viewer
