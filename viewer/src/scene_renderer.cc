#include "scene_renderer.h"

#include <algorithm>
#include <cstddef>
#include <string>

#include "detail_scale.h"
#include "dysa/codec/detail_subset.h"
#include "obstacle_placement.h"
#include "speed_colors.h"
#include "sphere_impostor.h"

namespace dysa::viewer {

namespace {

// Sphere impostors (sphere_impostor.h): each instance is a camera-facing quad just large enough
// for the sphere's outline; every fragment casts its view ray against the true sphere, so
// silhouettes, normals and depth are exact under perspective.
constexpr const char* kSphereVertexMain = R"(
layout(location = 0) in vec4 instance;  // xyz: centre (m); w: speed (m/s) or radius (m)
uniform mat4 view;
uniform mat4 projection;
uniform float radius;          // m; <= 0: the instance's w is the radius
out vec3 quad_view;            // this corner in view space
flat out vec3 center_view;
flat out float sphere_radius;
flat out float speed;
const vec2 kCorners[4] = vec2[4](vec2(-1, -1), vec2(1, -1), vec2(-1, 1), vec2(1, 1));
void main() {
  float r = radius > 0.0 ? radius : instance.w;
  vec4 c = view * vec4(instance.xyz, 1.0);
  center_view = c.xyz;
  sphere_radius = r;
  speed = instance.w;
  quad_view = vec3(c.xy + kCorners[gl_VertexID] * ImpostorHalfWidth(c.xyz, r), c.z);
  gl_Position = projection * vec4(quad_view, 1.0);
}
)";

constexpr const char* kSphereFragmentMain = R"(
in vec3 quad_view;
flat in vec3 center_view;
flat in float sphere_radius;
flat in float speed;
uniform mat4 projection;
uniform sampler2D gradient;  // 256 x 1 speed colours
uniform vec2 speed_range;    // m/s, the gradient's ends
uniform vec3 flat_color;     // used when use_gradient == 0
uniform int use_gradient;
out vec4 color;
void main() {
  vec3 d = normalize(quad_view);
  float t_near, t_far;
  if (!IntersectSphere(d, center_view, sphere_radius, t_near, t_far)) discard;
  vec3 hit = d * t_near;
  vec3 n = (hit - center_view) / sphere_radius;
  vec4 clip = projection * vec4(hit, 1.0);
  gl_FragDepth = 0.5 * clip.z / clip.w + 0.5;
  vec3 base = flat_color;
  if (use_gradient != 0) {
    float t = clamp((speed - speed_range.x) / max(speed_range.y - speed_range.x, 1e-6), 0.0, 1.0);
    base = texture(gradient, vec2(t, 0.5)).rgb;
  }
  vec3 light = normalize(vec3(0.35, 0.8, 0.5));  // view space, from above and behind the eye
  float diffuse = max(dot(n, light), 0.0);
  float specular = pow(max(dot(n, normalize(light - d)), 0.0), 48.0);
  color = vec4(base * (0.28 + 0.72 * diffuse) + 0.3 * specular, 1.0);
}
)";

constexpr const char* kLineVertex = R"(
layout(location = 0) in vec3 position;
uniform mat4 view_projection;
void main() { gl_Position = view_projection * vec4(position, 1.0); }
)";

constexpr const char* kLineFragment = R"(
uniform vec3 line_color;
out vec4 color;
void main() { color = vec4(line_color, 1.0); }
)";

// A unit-cube vertex scaled onto one box instance: corner weights 0 or 1 per axis pick its lo or
// hi coordinate; the faces stay axis-aligned, so the cube's normals hold.
constexpr const char* kLitVertex = R"(
layout(location = 0) in vec3 corner;
layout(location = 1) in vec3 normal;
layout(location = 2) in vec3 lo;  // m, the box's smallest corner
layout(location = 3) in vec3 hi;  // m, its largest
uniform mat4 view;
uniform mat4 projection;
out vec3 normal_view;
void main() {
  normal_view = mat3(view) * normal;
  gl_Position = projection * view * vec4(mix(lo, hi, corner), 1.0);
}
)";

constexpr const char* kLitFragment = R"(
in vec3 normal_view;
uniform vec3 base_color;
out vec4 color;
void main() {
  vec3 light = normalize(vec3(0.35, 0.8, 0.5));
  float diffuse = abs(dot(normalize(normal_view), light));
  color = vec4(base_color * (0.3 + 0.7 * diffuse), 1.0);
}
)";

constexpr float kObstacleGrey[3] = {0.62f, 0.63f, 0.66f};

void SetMatrix(GLint location, const Eigen::Matrix4f& m) {
  glUniformMatrix4fv(location, 1, GL_FALSE, m.data());  // Eigen is column-major, like GLSL
}

Eigen::Vector3f ToVector(const std::array<double, 3>& a) {
  return Eigen::Vector3f(float(a[0]), float(a[1]), float(a[2]));
}

// The 12 edges of the box [lo, hi] as 24 line vertices.
void AppendBoxEdges(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi, std::vector<float>& out) {
  auto corner = [&](int i) {
    return Eigen::Vector3f((i & 1) ? hi.x() : lo.x(), (i & 2) ? hi.y() : lo.y(),
                           (i & 4) ? hi.z() : lo.z());
  };
  for (int i = 0; i < 8; ++i) {
    for (int axis = 0; axis < 3; ++axis) {
      const int j = i | (1 << axis);
      if (j == i) continue;  // each edge once, from its lower corner
      for (const Eigen::Vector3f& p : {corner(i), corner(j)})
        out.insert(out.end(), {p.x(), p.y(), p.z()});
    }
  }
}

// The 6 faces of the box [lo, hi] as 36 vertices of position and outward normal.
void AppendBoxFaces(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi, std::vector<float>& out) {
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3;
    const int v = (axis + 2) % 3;
    for (int side = 0; side < 2; ++side) {
      Eigen::Vector3f normal = Eigen::Vector3f::Zero();
      normal[axis] = side ? 1.0f : -1.0f;
      auto vertex = [&](int a, int b) {
        Eigen::Vector3f p;
        p[axis] = side ? hi[axis] : lo[axis];
        p[u] = a ? hi[u] : lo[u];
        p[v] = b ? hi[v] : lo[v];
        out.insert(out.end(), {p.x(), p.y(), p.z(), normal.x(), normal.y(), normal.z()});
      };
      // Lighting uses |n . l|, so the winding does not matter (no face culling).
      vertex(0, 0), vertex(1, 0), vertex(1, 1);
      vertex(0, 0), vertex(1, 1), vertex(0, 1);
    }
  }
}

}  // namespace

SceneRenderer::SceneRenderer()
    : sphere_program_(LinkProgram(
          "sphere impostor", (std::string(kImpostorHalfWidthGlsl) + kSphereVertexMain).c_str(),
          (std::string(kIntersectSphereGlsl) + kSphereFragmentMain).c_str())),
      line_program_(LinkProgram("line", kLineVertex, kLineFragment)),
      lit_program_(LinkProgram("lit solid", kLitVertex, kLitFragment)),
      gradient_(MakeTexture()),
      particle_vao_(MakeVertexArray()),
      particle_buffer_(MakeBuffer()),
      obstacle_vao_(MakeVertexArray()),
      obstacle_buffer_(MakeBuffer()),
      box_vao_(MakeVertexArray()),
      box_buffer_(MakeBuffer()),
      solid_vao_(MakeVertexArray()),
      cube_buffer_(MakeBuffer()),
      solid_buffer_(MakeBuffer()) {
  const std::vector<unsigned char> table = SpeedColorTable(256);
  glBindTexture(GL_TEXTURE_2D, gradient_.get());
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGB8, 256, 1, 0, GL_RGB, GL_UNSIGNED_BYTE, table.data());
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  glBindTexture(GL_TEXTURE_2D, 0);

  // Instanced vec4 per sphere (particles and obstacles alike).
  for (auto [vao, buffer] : {std::pair{particle_vao_.get(), particle_buffer_.get()},
                             std::pair{obstacle_vao_.get(), obstacle_buffer_.get()}}) {
    glBindVertexArray(vao);
    glBindBuffer(GL_ARRAY_BUFFER, buffer);
    glEnableVertexAttribArray(0);
    glVertexAttribPointer(0, 4, GL_FLOAT, GL_FALSE, 4 * sizeof(float), nullptr);
    glVertexAttribDivisor(0, 1);
  }
  glBindVertexArray(box_vao_.get());
  glBindBuffer(GL_ARRAY_BUFFER, box_buffer_.get());
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 3 * sizeof(float), nullptr);
  std::vector<float> cube;
  AppendBoxFaces(Eigen::Vector3f::Zero(), Eigen::Vector3f::Ones(), cube);
  glBindVertexArray(solid_vao_.get());
  glBindBuffer(GL_ARRAY_BUFFER, cube_buffer_.get());
  glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(cube.size() * sizeof(float)), cube.data(),
               GL_STATIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float),
                        reinterpret_cast<const void*>(3 * sizeof(float)));
  glBindBuffer(GL_ARRAY_BUFFER, solid_buffer_.get());
  for (GLuint location : {2u, 3u}) {  // lo, then hi, per instance
    glEnableVertexAttribArray(location);
    glVertexAttribPointer(location, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float),
                          reinterpret_cast<const void*>((location - 2) * 3 * sizeof(float)));
    glVertexAttribDivisor(location, 1);
  }
  glBindVertexArray(0);
  glBindBuffer(GL_ARRAY_BUFFER, 0);
}

SceneRenderer::~SceneRenderer() = default;

void SceneRenderer::SetScene(const remote::SceneDescription& scene) {
  particle_radius_ = scene.particle_radius > 0 ? float(scene.particle_radius) : 0.05f;

  std::vector<float> lines;
  AppendBoxEdges(ToVector(scene.domain_min), ToVector(scene.domain_max), lines);
  glBindBuffer(GL_ARRAY_BUFFER, box_buffer_.get());
  glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(lines.size() * sizeof(float)), lines.data(),
               GL_STATIC_DRAW);
  box_vertices_ = GLsizei(lines.size() / 3);

  spheres_ = scene.spheres;
  boxes_ = scene.boxes;
  obstacles_move_ = AnyObstacleMoves(scene);
  PlaceObstacles(obstacle_time_);
}

void SceneRenderer::PlaceObstacles(double time) {
  obstacle_time_ = time;
  // Dynamic draw when they move: re-uploaded whenever a frame of another time arrives.
  const GLenum usage = obstacles_move_ ? GL_DYNAMIC_DRAW : GL_STATIC_DRAW;
  const std::vector<float> spheres = SphereInstances(spheres_, time);
  glBindBuffer(GL_ARRAY_BUFFER, obstacle_buffer_.get());
  glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(spheres.size() * sizeof(float)), spheres.data(), usage);
  obstacle_count_ = GLsizei(spheres_.size());

  const std::vector<float> boxes = BoxInstances(boxes_, time);
  glBindBuffer(GL_ARRAY_BUFFER, solid_buffer_.get());
  glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(boxes.size() * sizeof(float)), boxes.data(), usage);
  solid_count_ = GLsizei(boxes_.size());
  glBindBuffer(GL_ARRAY_BUFFER, 0);
}

void SceneRenderer::UploadParticles(const codec::Frame& frame) {
  const size_t n = frame.count;
  staging_.resize(4 * n);
  const bool has_speed = frame.speed.size() == n;
  for (size_t i = 0; i < n; ++i) {
    staging_[4 * i + 0] = frame.positions[3 * i + 0];
    staging_[4 * i + 1] = frame.positions[3 * i + 1];
    staging_[4 * i + 2] = frame.positions[3 * i + 2];
    staging_[4 * i + 3] = has_speed ? frame.speed[i] : 0.0f;
  }
  glBindBuffer(GL_ARRAY_BUFFER, particle_buffer_.get());
  // A fresh data store each frame (orphaning): the driver need not wait for draws that still
  // read the previous frame's particles.
  glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(staging_.size() * sizeof(float)), staging_.data(),
               GL_STREAM_DRAW);
  glBindBuffer(GL_ARRAY_BUFFER, 0);
  particle_count_ = GLsizei(n);
  detail_ = codec::DetailFraction(frame.detail_threshold);
  detail_scale_ = DetailRadiusScale(detail_);
  if (obstacles_move_ && frame.time != obstacle_time_) PlaceObstacles(frame.time);
}

ParticleBuffer SceneRenderer::Particles(const SceneStyle& style) const {
  return {particle_vao_.get(), particle_count_,
          particle_radius_ * style.particle_scale * detail_scale_};
}

void SceneRenderer::DrawEnvironment(const ViewParams& view, const SceneStyle& style) {
  glViewport(0, 0, view.width, view.height);
  glClearColor(style.background[0], style.background[1], style.background[2], 1.0f);
  glClearDepth(1.0);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDisable(GL_BLEND);

  if (style.draw_box && box_vertices_ > 0) {
    glUseProgram(line_program_.get());
    SetMatrix(Uniform(line_program_, "view_projection"), view.projection * view.view);
    glUniform3f(Uniform(line_program_, "line_color"), 0.55f, 0.58f, 0.64f);
    glBindVertexArray(box_vao_.get());
    glDrawArrays(GL_LINES, 0, box_vertices_);
  }
  if (style.draw_obstacles && solid_count_ > 0) {
    glUseProgram(lit_program_.get());
    SetMatrix(Uniform(lit_program_, "view"), view.view);
    SetMatrix(Uniform(lit_program_, "projection"), view.projection);
    glUniform3fv(Uniform(lit_program_, "base_color"), 1, kObstacleGrey);
    glBindVertexArray(solid_vao_.get());
    glDrawArraysInstanced(GL_TRIANGLES, 0, 36, solid_count_);
  }
  if (style.draw_obstacles && obstacle_count_ > 0) {
    glUseProgram(sphere_program_.get());
    SetMatrix(Uniform(sphere_program_, "view"), view.view);
    SetMatrix(Uniform(sphere_program_, "projection"), view.projection);
    glUniform1f(Uniform(sphere_program_, "radius"), 0.0f);  // per instance
    glUniform1i(Uniform(sphere_program_, "use_gradient"), 0);
    glUniform3fv(Uniform(sphere_program_, "flat_color"), 1, kObstacleGrey);
    glBindVertexArray(obstacle_vao_.get());
    glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, obstacle_count_);
  }
  glBindVertexArray(0);
  glUseProgram(0);
}

void SceneRenderer::DrawParticles(const ViewParams& view, const SceneStyle& style) {
  if (particle_count_ == 0) return;
  glEnable(GL_DEPTH_TEST);
  glUseProgram(sphere_program_.get());
  SetMatrix(Uniform(sphere_program_, "view"), view.view);
  SetMatrix(Uniform(sphere_program_, "projection"), view.projection);
  glUniform1f(Uniform(sphere_program_, "radius"),
              particle_radius_ * style.particle_scale * detail_scale_);
  glUniform1i(Uniform(sphere_program_, "use_gradient"), 1);
  glUniform2f(Uniform(sphere_program_, "speed_range"), style.speed_lo, style.speed_hi);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, gradient_.get());
  glUniform1i(Uniform(sphere_program_, "gradient"), 0);
  glBindVertexArray(particle_vao_.get());
  glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, particle_count_);
  glBindVertexArray(0);
  glBindTexture(GL_TEXTURE_2D, 0);
  glUseProgram(0);
}

}  // namespace dysa::viewer
