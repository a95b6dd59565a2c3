// What the renderers share: the camera's matrices, the viewport and the particles' GPU buffer.
#pragma once

#include <Eigen/Core>

#include "gl.h"

namespace dysa::viewer {

struct ViewParams {
  Eigen::Matrix4f view;        // world to view
  Eigen::Matrix4f projection;  // view to clip (OpenGL)
  int width = 0;               // viewport, pixels
  int height = 0;
  float near_plane = 0.1f;  // m, the projection's planes
  float far_plane = 100.0f;
};

// The particles of the newest frame on the GPU. `vertex_array` has one attribute, location 0:
// a vec4 per particle (x, y, z in metres; w = speed in m/s), with divisor 1, so a draw call
// glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, count) gives each particle a quad whose
// corner is gl_VertexID (0..3).
struct ParticleBuffer {
  GLuint vertex_array = 0;
  GLsizei count = 0;
  float radius = 0.05f;  // m, drawn radius of a particle
};

}  // namespace dysa::viewer
