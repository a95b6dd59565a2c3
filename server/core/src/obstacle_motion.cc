// ObstacleMotion: a piecewise linear displacement in time (scene.h).
#include <algorithm>

#include "dysa/core/scene.h"

namespace dysa {
namespace {

// The index of the first key later than t (keys.size() when none is).
size_t FirstKeyAfter(const std::vector<ObstacleMotion::Key>& keys, double t) {
  return size_t(
      std::upper_bound(keys.begin(), keys.end(), t,
                       [](double time, const ObstacleMotion::Key& k) { return time < k.time; }) -
      keys.begin());
}

}  // namespace

Vec3d ObstacleMotion::DisplacementAt(double t) const {
  if (keys.empty()) return Vec3d::Zero();
  const size_t next = FirstKeyAfter(keys, t);
  if (next == 0) return keys.front().displacement;
  if (next == keys.size()) return keys.back().displacement;
  const Key& a = keys[next - 1];
  const Key& b = keys[next];
  // At t == a.time exactly this is a's displacement: s is 0.
  const double s = (t - a.time) / (b.time - a.time);
  return a.displacement + s * (b.displacement - a.displacement);
}

Vec3d ObstacleMotion::VelocityAt(double t) const {
  const size_t next = FirstKeyAfter(keys, t);
  if (next == 0 || next == keys.size()) return Vec3d::Zero();
  const Key& a = keys[next - 1];
  const Key& b = keys[next];
  return (b.displacement - a.displacement) / (b.time - a.time);
}

}  // namespace dysa
