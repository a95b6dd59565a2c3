// Screen-space fluid rendering (van der Laan, Green & Sainz, "Screen Space Fluid Rendering with
// Curvature Flow", I3D 2009; Green, "Screen Space Fluid Rendering for Games", GDC 2010): the
// particles' front depth and their thickness are rendered to textures, the depth is smoothed
// with a separable bilateral filter, normals come from the smoothed depth, and the surface is
// shaded with Fresnel reflection and a refraction-like view of the scene behind it, tinted by
// Beer-Lambert absorption over the thickness.
#pragma once

#include <memory>

#include "gl_util.h"
#include "render_types.h"

namespace dysa::viewer {

struct FluidStyle {
  // The bilateral filter's half-width is filter_radius_particles surface radii in the world, so
  // it shrinks on screen with distance; filter_radius_pixels caps it for near fluid and bounds
  // the cost (2 filter_radius_pixels + 1 taps per pixel and pass, up to 64 pixels).
  float filter_radius_particles = 3.0f;
  float filter_radius_pixels = 16.0f;
  int smoothing_iterations = 2;         // passes of the separable filter
  float thickness_per_particle = 0.5f;  // fraction of a particle's diameter added to thickness
  float absorption[3] = {1.2f, 0.5f, 0.25f};     // per metre of thickness, red/green/blue
  float water_color[3] = {0.10f, 0.42f, 0.80f};  // light scattered inside the water (RGB)
  float refraction_pixels = 24.0f;               // background offset at full normal tilt
};

class FluidRenderer {
 public:
  FluidRenderer();  // compiles the shaders; needs a current OpenGL 3.3 core context
  ~FluidRenderer();
  FluidRenderer(const FluidRenderer&) = delete;
  FluidRenderer& operator=(const FluidRenderer&) = delete;

  // Draws the fluid surface of `particles` over the scene into `target_framebuffer` (0: the
  // window), covering the whole viewport. `scene_color` (RGBA8) and `scene_depth` (depth
  // texture, window-space depth of the projection in `view`) hold the scene without the fluid
  // at the viewport's size; pixels where the scene is nearer than the fluid keep the scene.
  void Render(const ViewParams& view, const ParticleBuffer& particles, GLuint scene_color,
              GLuint scene_depth, GLuint target_framebuffer, const FluidStyle& style);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dysa::viewer
