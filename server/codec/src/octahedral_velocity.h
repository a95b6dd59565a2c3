// The octahedral velocity encoding (FORMAT.md, "Velocity"): |v| plus the direction n mapped to
// the octahedron |x| + |y| + |z| = 1, whose lower half folds over the upper one, then to (u, v)
// in [-1, 1]^2 (Cigolle et al. 2014).
#pragma once

#include <array>
#include <cmath>

#include "chunk_header.h"
#include "dysa/codec/frame_codec.h"
#include "quantisation.h"

namespace dysa::codec {

inline double SignNotZero(double x) { return x >= 0 ? 1.0 : -1.0; }

// (|v|, u, v) of a velocity, in double precision. The zero vector maps to (0, 0, 0). Inline: the
// gather calls it per particle.
inline std::array<double, 3> ToOctahedral(double x, double y, double z) {
  const double magnitude = std::sqrt(x * x + y * y + z * z);
  if (!(magnitude > 0)) return {magnitude, 0.0, 0.0};  // also NaN: quantises to 0
  const double l1 = std::abs(x) + std::abs(y) + std::abs(z);
  const double px = x / l1, py = y / l1;
  if (z >= 0) return {magnitude, px, py};
  return {magnitude, (1.0 - std::abs(py)) * SignNotZero(px),
          (1.0 - std::abs(px)) * SignNotZero(py)};
}

// Decodes the chunk's velocities from their quantised |v|, u and v (components kVelX, kVelY and
// kVelZ of q) into the frame.
void DequantizeOctahedral(const ChunkHeader& h, const Values& q, Frame& frame);

// The largest error of a decoded velocity component.
double OctahedralErrorBound(double velocity_max, int bits);

}  // namespace dysa::codec
