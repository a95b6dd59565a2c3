#include "octahedral_velocity.h"

#include <limits>

namespace dysa::codec {
namespace {

// The decoded velocity: the point of the octahedron at (u, v), scaled to |v| = magnitude. Every
// operation is a double-precision IEEE operation in this order, so the Python decoder gives the
// same floats.
void FromOctahedral(double magnitude, double u, double v, float* out) {
  const double au = std::abs(u), av = std::abs(v);
  const double z = 1.0 - au - av;
  if (z < 0) {
    const double fu = (1.0 - av) * SignNotZero(u);
    const double fv = (1.0 - au) * SignNotZero(v);
    u = fu;
    v = fv;
  }
  const double scale = magnitude / std::sqrt(u * u + v * v + z * z);
  out[0] = float(u * scale);
  out[1] = float(v * scale);
  out[2] = float(z * scale);
}

}  // namespace

void DequantizeOctahedral(const ChunkHeader& h, const Values& q, Frame& frame) {
  const uint32_t m = h.chunk_particles;
  if (m == 0) return;  // an empty frame: its arrays may be empty
  const uint32_t levels = Levels(h.velocity_bits);
  const double magnitude_step = h.velocity_max / double(levels);
  const double coordinate_step = 2.0 / double(levels);
  const uint32_t* qm = q[kVelX].data() + h.first;
  const uint32_t* qu = q[kVelY].data() + h.first;
  const uint32_t* qv = q[kVelZ].data() + h.first;
  float* out = frame.velocities.data() + 3 * size_t(h.first);
  for (uint32_t k = 0; k < m; ++k) {
    FromOctahedral(0.0 + double(qm[k]) * magnitude_step, -1.0 + double(qu[k]) * coordinate_step,
                   -1.0 + double(qv[k]) * coordinate_step, out + 3 * size_t(k));
  }
}

// The bound on each component of an octahedral velocity, from |v1 - v0| <= |m1 - m0| +
// m0 |n1 - n0| with m the magnitude and n the direction. The magnitude is off by at most half a
// step, velocity_max / (2 L). Each coordinate is off by at most half its step, 1 / L, so (u, v)
// moves by at most sqrt(2) / L; the octahedron point p(u, v) is piecewise linear with gradient
// norm at most sqrt(3), and |p| >= 1 / sqrt(3) because |p|_1 = 1; with
// |a / |a| - b / |b|| <= 2 |a - b| / |a| the direction moves by at most
// 2 sqrt(3) sqrt(3) sqrt(2) / L = 6 sqrt(2) / L. Float rounding of the gathered values and of
// the result adds a few float epsilons of velocity_max.
double OctahedralErrorBound(double velocity_max, int bits) {
  const double levels = double(Levels(bits));
  return velocity_max *
         ((0.5 + 6.0 * std::sqrt(2.0)) / levels + 8 * std::numeric_limits<float>::epsilon());
}

}  // namespace dysa::codec
