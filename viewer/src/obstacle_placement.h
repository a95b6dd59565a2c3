// Where the scene's obstacles are at a frame's simulated time, as the renderer's instance data:
// each obstacle at its given position plus its motion's displacement at that time (the core's
// piecewise linear path, dysa/client/types.h), so stepping back or resetting shows it where it
// was. No OpenGL here: tested without a display.
#pragma once

#include <vector>

#include "dysa/client/types.h"

namespace dysa::viewer {

// True when some obstacle has a motion: only then does the time of a frame change the drawing.
bool AnyObstacleMoves(const remote::SceneDescription& scene);

// Per sphere: centre x, y, z and radius (m) at simulated time `time` (s).
std::vector<float> SphereInstances(const std::vector<remote::SphereObstacle>& spheres, double time);

// Per box: its smallest corner x, y, z then its largest (m) at simulated time `time` (s).
std::vector<float> BoxInstances(const std::vector<remote::BoxObstacle>& boxes, double time);

}  // namespace dysa::viewer
