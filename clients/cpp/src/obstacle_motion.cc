// ObstacleMotion::DisplacementAt (dysa/client/types.h): the core's piecewise linear path
// (server/core/src/obstacle_motion.cc), evaluated on this side so that a viewer draws an
// obstacle where the solver had it at a frame's time without asking the server.
#include <algorithm>

#include "dysa/client/types.h"

namespace dysa::remote {

std::array<double, 3> ObstacleMotion::DisplacementAt(double t) const {
  if (keys.empty()) return {0, 0, 0};
  // The first key later than t: the segment [next - 1, next] holds t.
  const auto next = std::upper_bound(keys.begin(), keys.end(), t,
                                     [](double time, const Key& k) { return time < k.time; });
  if (next == keys.begin()) return keys.front().displacement;
  if (next == keys.end()) return keys.back().displacement;
  const Key& a = *(next - 1);
  const Key& b = *next;
  // Here a.time <= t < b.time, unless a key time is not a number (dysa-server never sends one):
  // then the later key, not a NaN displacement.
  if (!(b.time > a.time)) return b.displacement;
  const double s = (t - a.time) / (b.time - a.time);
  std::array<double, 3> d;
  for (int i = 0; i < 3; ++i)
    d[i] = a.displacement[i] + s * (b.displacement[i] - a.displacement[i]);
  return d;
}

}  // namespace dysa::remote
