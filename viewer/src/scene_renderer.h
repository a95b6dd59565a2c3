// Draws what the server simulates: the particles as shaded sphere impostors coloured by speed,
// the domain box as lines, sphere obstacles as grey impostors and box obstacles as lit cubes,
// each obstacle where its motion has it at the shown frame's simulated time.
// Needs a current OpenGL 3.3 core context.
#pragma once

#include <array>
#include <vector>

#include "dysa/client/types.h"
#include "dysa/codec/frame_codec.h"
#include "gl_util.h"
#include "render_types.h"

namespace dysa::viewer {

struct SceneStyle {
  float speed_lo = 0.0f;        // m/s: the slow (blue) end of the colour gradient
  float speed_hi = 10.0f;       // m/s: the fast (red) end (a fall from 5 m reaches 10 m/s)
  float particle_scale = 1.0f;  // drawn radius over the scene's particle radius
  bool draw_box = true;
  bool draw_obstacles = true;
  std::array<float, 3> background = {0.11f, 0.12f, 0.14f};
};

class SceneRenderer {
 public:
  SceneRenderer();
  ~SceneRenderer();
  SceneRenderer(const SceneRenderer&) = delete;
  SceneRenderer& operator=(const SceneRenderer&) = delete;

  // The domain box, obstacles and particle radius of the scene now running; its obstacles are
  // drawn at the latest frame's time until the next frame.
  void SetScene(const remote::SceneDescription& scene);
  // One buffer upload: each particle's position and speed (0 when the frame has no speed). The
  // moving obstacles go where they are at the frame's time.
  void UploadParticles(const codec::Frame& frame);
  // The latest frame's detail (the fraction of the particles it holds) and the factor its
  // particles are drawn larger by (detail_scale.h).
  double detail() const { return detail_; }
  float detail_scale() const { return detail_scale_; }

  // The particles on the GPU with the drawn radius for `style`.
  ParticleBuffer Particles(const SceneStyle& style) const;

  // Clears the bound framebuffer to the background and draws the box and obstacles.
  void DrawEnvironment(const ViewParams& view, const SceneStyle& style);
  void DrawParticles(const ViewParams& view, const SceneStyle& style);

 private:
  Program sphere_program_;
  Program line_program_;
  Program lit_program_;
  Texture gradient_;

  VertexArray particle_vao_;
  Buffer particle_buffer_;
  GLsizei particle_count_ = 0;
  std::vector<float> staging_;  // interleaved x, y, z, speed

  VertexArray obstacle_vao_;  // sphere obstacles: centre and radius per instance
  Buffer obstacle_buffer_;
  GLsizei obstacle_count_ = 0;

  VertexArray box_vao_;  // domain box edges
  Buffer box_buffer_;
  GLsizei box_vertices_ = 0;

  // Box obstacles: a unit cube (corner weights and normal per vertex), instanced with each
  // box's smallest and largest corner.
  VertexArray solid_vao_;
  Buffer cube_buffer_;
  Buffer solid_buffer_;
  GLsizei solid_count_ = 0;

  // The obstacles as sent (positions without displacement) and the time they are drawn at.
  std::vector<remote::SphereObstacle> spheres_;
  std::vector<remote::BoxObstacle> boxes_;
  bool obstacles_move_ = false;
  double obstacle_time_ = 0;  // s

  // Uploads the obstacles' instance data at simulated time `time`.
  void PlaceObstacles(double time);

  float particle_radius_ = 0.05f;  // m
  double detail_ = 1;
  float detail_scale_ = 1;
};

}  // namespace dysa::viewer
