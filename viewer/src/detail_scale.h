// How much larger to draw each particle of a frame that holds only a fraction of them (a
// budgeted stream's detail, docs/server.md "Budgets and detail"), so that the fluid stays closed.
//
// Volume scaling: radius x (1 / fraction)^(1/3). The subset is a uniform sample of a 3D fluid,
// so its spacing grows by (1 / fraction)^(1/3); spheres that grow by as much fill the same
// fraction of the volume as the full set did, and overlap their neighbours as much: the bulk,
// its silhouette and the fluid renderer's surface stay as closed as at full detail. Area
// scaling, (1 / fraction)^(1/2), would keep a one-particle-thick sheet closed, but inflates the
// bulk (at a detail of 1/64: 8 radii rather than 4), blurring the shape a budget is meant to
// keep; thin sheets may open at low detail instead.
#pragma once

#include <algorithm>
#include <cmath>

namespace dysa::viewer {

inline float DetailRadiusScale(double fraction) {
  if (!(fraction > 0) || fraction >= 1) return 1.0f;
  return float(std::cbrt(1.0 / std::max(fraction, 1.0 / 4096)));
}

}  // namespace dysa::viewer
