#include "fluid_renderer.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <string>

#include "sphere_impostor.h"

namespace dysa::viewer {

namespace {

// ---------------------------------------------------------------------------------------------
// Shaders. All passes see the particles as spheres of radius `radius`, the caller's surface
// radius: about the particle spacing or more, so that neighbours overlap into one surface.

// Sphere impostors: see sphere_impostor.h.
constexpr const char* kImpostorVertexMain = R"(
layout(location = 0) in vec4 instance;  // xyz: centre (m); w: speed (unused)
uniform mat4 view;
uniform mat4 projection;
uniform float radius;
out vec3 quad_view;
flat out vec3 center_view;
const vec2 kCorners[4] = vec2[4](vec2(-1, -1), vec2(1, -1), vec2(-1, 1), vec2(1, 1));
void main() {
  vec4 c = view * vec4(instance.xyz, 1.0);
  center_view = c.xyz;
  quad_view = vec3(c.xy + kCorners[gl_VertexID] * ImpostorHalfWidth(c.xyz, radius), c.z);
  gl_Position = projection * vec4(quad_view, 1.0);
}
)";

// Shared by the fluid's fragment shaders, after IntersectSphere (sphere_impostor.h).
constexpr const char* kRaySphere = R"(
// Window depth (what the depth buffer holds) back to the distance in front of the eye along
// -z, for an OpenGL perspective projection with planes n and f:
// z_ndc = (f + n - 2 f n / z_eye) / (f - n)  =>  z_eye = 2 f n / (f + n - z_ndc (f - n)).
uniform vec2 near_far;
float EyeDepth(float window_depth) {
  float z_ndc = 2.0 * window_depth - 1.0;
  float n = near_far.x;
  float f = near_far.y;
  return 2.0 * f * n / (f + n - z_ndc * (f - n));
}
)";

// Depth pass: the nearest sphere surface's eye depth (positive, metres) goes to the colour
// target; gl_FragDepth makes the depth test pick the nearest surface, not the nearest quad.
// Fragments behind the scene (obstacles, floor) are dropped here, so hidden fluid never takes
// part in the smoothing and the composite sees only visible fluid.
constexpr const char* kDepthFragment = R"(
in vec3 quad_view;
flat in vec3 center_view;
uniform mat4 projection;
uniform float radius;
uniform sampler2D scene_depth;  // window depth, full resolution
layout(location = 0) out float eye_depth;
void main() {
  vec3 d = normalize(quad_view);
  float t_near, t_far;
  // A miss, or the eye inside the sphere (its front is behind the eye).
  if (!IntersectSphere(d, center_view, radius, t_near, t_far) || t_near <= 0.0) discard;
  vec3 hit = d * t_near;
  vec4 clip = projection * vec4(hit, 1.0);
  float window_depth = 0.5 * clip.z / clip.w + 0.5;
  if (window_depth >= texelFetch(scene_depth, ivec2(gl_FragCoord.xy), 0).r) discard;
  gl_FragDepth = window_depth;
  eye_depth = -hit.z;
}
)";

// Thickness pass, blended additively: each sphere adds the length of its chord along the view
// ray (times thickness_per_particle, because neighbouring spheres overlap), so the sum is a
// smooth estimate of how much fluid light crosses. The chord is cut where the scene begins, so
// an obstacle inside or behind the fluid only counts the fluid in front of it, and fluid
// entirely behind an obstacle adds nothing; no depth buffer is needed for that, and the pass
// can run at a lower resolution than the scene depth it reads.
constexpr const char* kThicknessFragment = R"(
in vec3 quad_view;
flat in vec3 center_view;
uniform float radius;
uniform float thickness_per_particle;
uniform sampler2D scene_depth;  // window depth, full resolution
uniform vec2 scene_scale;       // full-resolution pixels per thickness pixel
layout(location = 0) out float thickness;
void main() {
  vec3 d = normalize(quad_view);
  float t_near, t_far;
  if (!IntersectSphere(d, center_view, radius, t_near, t_far)) discard;
  // The scene's surface along this ray: its eye depth over the ray's -z per unit length.
  ivec2 p = ivec2(gl_FragCoord.xy * scene_scale);
  float t_scene = EyeDepth(texelFetch(scene_depth, p, 0).r) / max(-d.z, 1e-4);
  float chord = min(t_far, t_scene) - max(t_near, 0.0);
  if (chord <= 0.0) discard;
  thickness = chord * thickness_per_particle;
}
)";

// One triangle that covers the viewport: (-1,-1), (3,-1), (-1,3).
constexpr const char* kFullScreenVertex = R"(
void main() {
  vec2 p = vec2((gl_VertexID & 1) * 4 - 1, (gl_VertexID >> 1) * 4 - 1);
  gl_Position = vec4(p, 0.0, 1.0);
}
)";

// One direction of the separable bilateral filter on the eye depth (0: no fluid). The spatial
// Gaussian has a constant size in the world (world_radius metres), so on screen it is
// world_radius * pixels_per_metre / depth pixels wide, capped at max_radius pixels (the cost is
// 2 max_radius + 1 taps per pixel and pass). The range weight exp(-(dz / depth_falloff)^2)
// keeps separate layers of fluid (a splash in front of the pool) from being blurred into each
// other; background pixels neither change nor contribute. A bilateral filter is not truly
// separable, but horizontal and vertical passes, repeated, smooth the particles' bumps well
// (van der Laan et al. use curvature flow instead; the bilateral filter is Green's cheaper
// choice). Every pixel within the kernel is sampled: sparser sampling makes which samples fall
// on fluid jump from pixel to pixel near the outline, and the normals show it as streaks.
constexpr const char* kFilterFragment = R"(
uniform sampler2D depth;
uniform ivec2 direction;         // (1, 0) or (0, 1)
uniform float world_radius;      // m, kernel half-width in the world
uniform float pixels_per_metre;  // on screen, for something 1 m in front of the eye
uniform float max_radius;        // pixels
uniform float depth_falloff;     // m
layout(location = 0) out float result;
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  float z = texelFetch(depth, p, 0).r;
  result = z;
  if (z <= 0.0) return;
  float radius = min(world_radius * pixels_per_metre / z, max_radius);
  if (radius < 1.0) return;
  int taps = int(ceil(radius));
  float sigma = 0.5 * radius;  // the kernel ends at two standard deviations
  float spatial = -0.5 / (sigma * sigma);
  float range = -1.0 / (depth_falloff * depth_falloff);
  ivec2 last = textureSize(depth, 0) - 1;
  float sum = z;
  float weights = 1.0;
  for (int i = -taps; i <= taps; ++i) {
    if (i == 0) continue;
    float s = texelFetch(depth, clamp(p + i * direction, ivec2(0), last), 0).r;
    if (s <= 0.0) continue;
    float dz = s - z;
    float w = exp(spatial * float(i * i) + range * dz * dz);
    sum += w * s;
    weights += w;
  }
  result = sum / weights;
}
)";

// The composite: the smoothed surface shaded over the scene, the scene everywhere else.
constexpr const char* kCompositeFragment = R"(
uniform sampler2D fluid_depth;  // smoothed eye depth, 0: no fluid
uniform sampler2D thickness;    // m, possibly at a lower resolution (filtered)
uniform sampler2D scene_color;
uniform sampler2D scene_depth;
uniform mat4 inverse_projection;
uniform mat3 view_to_world;       // rotation only
uniform vec3 absorption;          // 1/m
uniform vec3 water_color;         // linear RGB of the light the water scatters
uniform float refraction_pixels;  // background offset at full tilt
uniform float radius;             // m, the surface radius of a particle
layout(location = 0) out vec4 color;
ivec2 size;

// The view-space point at eye depth z on the ray through the centre of pixel p. The inverse
// projection takes the pixel's NDC point on the far plane back to view space; scaling it to
// z = -1 and then by z lands on the surface.
vec3 ViewPosition(ivec2 p, float z) {
  vec2 ndc = (vec2(p) + 0.5) / vec2(size) * 2.0 - 1.0;
  vec4 v = inverse_projection * vec4(ndc, 1.0, 1.0);
  return v.xyz / -v.z * z;
}

// The surface's tangent along one screen axis. Of the forward and backward differences, the
// one with the smaller change in depth is taken: at a silhouette or a step between layers the
// other one spans the gap and would tilt the normal sideways (a bright or dark rim).
vec3 Tangent(ivec2 p, vec3 here, ivec2 step) {
  ivec2 last = size - 1;
  ivec2 pf = clamp(p + step, ivec2(0), last);
  ivec2 pb = clamp(p - step, ivec2(0), last);
  float zf = texelFetch(fluid_depth, pf, 0).r;
  float zb = texelFetch(fluid_depth, pb, 0).r;
  bool has_f = zf > 0.0 && pf != p;
  bool has_b = zb > 0.0 && pb != p;
  vec3 forward = has_f ? ViewPosition(pf, zf) - here : vec3(0.0);
  vec3 backward = has_b ? here - ViewPosition(pb, zb) : vec3(0.0);
  if (has_f && has_b) return abs(forward.z) < abs(backward.z) ? forward : backward;
  if (has_f) return forward;
  if (has_b) return backward;
  // An isolated pixel: face the camera.
  return step.x != 0 ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 1.0, 0.0);
}

// A simple sky: dark below the horizon, pale at the horizon, deeper blue overhead (world +y up).
vec3 Sky(vec3 direction_world) {
  float up = direction_world.y;
  vec3 ground = vec3(0.22, 0.22, 0.24);
  vec3 horizon = vec3(0.85, 0.9, 0.95);
  vec3 zenith = vec3(0.3, 0.5, 0.85);
  if (up < 0.0) return mix(horizon, ground, smoothstep(0.0, 0.25, -up));
  return mix(horizon, zenith, smoothstep(0.0, 0.6, up));
}

void main() {
  size = textureSize(fluid_depth, 0);
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec4 scene = texelFetch(scene_color, p, 0);
  float z = texelFetch(fluid_depth, p, 0).r;
  if (z <= 0.0 || EyeDepth(texelFetch(scene_depth, p, 0).r) < z) {
    color = scene;
    return;
  }

  vec3 position = ViewPosition(p, z);
  vec3 n = normalize(cross(Tangent(p, position, ivec2(1, 0)), Tangent(p, position, ivec2(0, 1))));
  vec3 to_eye = normalize(-position);
  if (dot(n, to_eye) < 0.0) n = -n;  // a degenerate cross product can point away

  vec2 uv = (vec2(p) + 0.5) / vec2(size);
  float t = texture(thickness, uv).r;

  // Refraction, faked in screen space: the scene behind is looked up displaced along the
  // normal's screen-space tilt, more so where the fluid is thick (a thin sheet barely bends
  // the view). The displacement saturates after a few particle diameters of fluid. Where the
  // displaced pixel is in front of the fluid (an obstacle), the undisplaced one is used, so
  // obstacles are not smeared into the water.
  float bend = refraction_pixels * (1.0 - exp(-t / (4.0 * radius)));
  vec2 refracted = clamp(uv + n.xy * bend / vec2(size), vec2(0.0), vec2(1.0));
  if (EyeDepth(texture(scene_depth, refracted).r) < z) refracted = uv;
  vec3 behind = texture(scene_color, refracted).rgb;  // filtered: the offset is fractional

  // Beer-Lambert: light crossing t metres keeps exp(-absorption t) of each channel. Red is
  // absorbed most, so deep water turns blue. A little in-scattered light keeps it from going
  // black where it is thick.
  // The in-scattered light is the water's own colour, lit by the same light as the surface, so
  // the body of the fluid stays visible (and its shape readable) over a dark background.
  vec3 transmittance = exp(-absorption * t);
  vec3 light = normalize(vec3(0.35, 0.8, 0.5));  // view space, above and behind the eye
  vec3 body = water_color * (0.45 + 0.55 * max(dot(n, light), 0.0));
  vec3 transmitted = behind * transmittance + body * (1.0 - transmittance);

  // Fresnel (Schlick, F0 = 0.02 for water against air): weak reflection when looking straight
  // down, strong at grazing angles.
  float cos_theta = clamp(dot(n, to_eye), 0.0, 1.0);
  float fresnel = 0.02 + 0.98 * pow(1.0 - cos_theta, 5.0);
  vec3 reflected = Sky(view_to_world * reflect(-to_eye, n));

  // Blinn-Phong highlight of the scene renderer's light.
  float specular = pow(max(dot(n, normalize(light + to_eye)), 0.0), 120.0);

  color = vec4(mix(transmitted, reflected, fresnel) + 0.6 * specular, 1.0);
}
)";

// The bilateral filter's range falloff, in surface radii: depth steps much larger than this
// (another layer of fluid) are not averaged; the bumps between neighbouring spheres (a fraction
// of a radius) are.
constexpr float kDepthFalloffRadii = 3.0f;

// An upper limit on filter_radius_pixels, so a slider cannot make a frame take seconds.
constexpr float kMaxFilterRadius = 64.0f;

// The thickness is accumulated at this fraction of the viewport's size in each axis: it only
// tints and bends, so its detail hardly shows, and it is the pass with the most overdraw.
constexpr int kThicknessDivisor = 2;

std::string WithRaySphere(const char* source) {
  return std::string(kIntersectSphereGlsl) + kRaySphere + source;
}
const std::string kImpostorVertex = std::string(kImpostorHalfWidthGlsl) + kImpostorVertexMain;

void SetMatrix(GLint location, const Eigen::Matrix4f& m) {
  glUniformMatrix4fv(location, 1, GL_FALSE, m.data());  // Eigen is column-major, like GLSL
}

void Attach(GLuint framebuffer, const Texture& color, const Texture* depth, const char* what) {
  glBindFramebuffer(GL_FRAMEBUFFER, framebuffer);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, color.get(), 0);
  if (depth != nullptr) {
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, depth->get(), 0);
  }
  CheckFramebuffer(what);
}

}  // namespace

struct FluidRenderer::Impl {
  Program depth_program;
  Program thickness_program;
  Program filter_program;
  Program composite_program;
  VertexArray empty_vao;  // the full-screen triangle has no attributes, but core needs a VAO

  // Eye depth ping-pong pair (R32F): depth_a holds the impostors' depth and, after each
  // filter iteration, the smoothed depth; depth_b the half-filtered one.
  Texture depth_a;
  Texture depth_b;
  Texture depth_buffer;  // for the depth test of the impostors
  Texture thickness;
  Framebuffer depth_a_fbo;
  Framebuffer depth_b_fbo;
  Framebuffer thickness_fbo;
  int width = 0;
  int height = 0;

  Impl()
      : depth_program(LinkProgram("fluid depth", kImpostorVertex.c_str(),
                                  WithRaySphere(kDepthFragment).c_str())),
        thickness_program(LinkProgram("fluid thickness", kImpostorVertex.c_str(),
                                      WithRaySphere(kThicknessFragment).c_str())),
        filter_program(LinkProgram("fluid depth filter", kFullScreenVertex, kFilterFragment)),
        composite_program(LinkProgram("fluid composite", kFullScreenVertex,
                                      WithRaySphere(kCompositeFragment).c_str())),
        empty_vao(MakeVertexArray()),
        depth_a(MakeTexture()),
        depth_b(MakeTexture()),
        depth_buffer(MakeTexture()),
        thickness(MakeTexture()),
        depth_a_fbo(MakeFramebuffer()),
        depth_b_fbo(MakeFramebuffer()),
        thickness_fbo(MakeFramebuffer()) {}

  int thickness_width() const { return std::max(1, width / kThicknessDivisor); }
  int thickness_height() const { return std::max(1, height / kThicknessDivisor); }

  void Resize(int new_width, int new_height) {
    if (new_width == width && new_height == height) return;
    width = new_width;
    height = new_height;
    AllocateTexture2D(depth_a, GL_R32F, width, height, GL_RED, GL_FLOAT, GL_NEAREST);
    AllocateTexture2D(depth_b, GL_R32F, width, height, GL_RED, GL_FLOAT, GL_NEAREST);
    AllocateTexture2D(depth_buffer, GL_DEPTH_COMPONENT24, width, height, GL_DEPTH_COMPONENT,
                      GL_UNSIGNED_INT, GL_NEAREST);
    // Linear filtering upsamples the lower-resolution thickness smoothly in the composite.
    AllocateTexture2D(thickness, GL_R16F, thickness_width(), thickness_height(), GL_RED, GL_FLOAT,
                      GL_LINEAR);
    Attach(depth_a_fbo.get(), depth_a, &depth_buffer, "fluid depth");
    Attach(depth_b_fbo.get(), depth_b, nullptr, "fluid depth (filter)");
    Attach(thickness_fbo.get(), thickness, nullptr, "fluid thickness");
  }
};

FluidRenderer::FluidRenderer() : impl_(std::make_unique<Impl>()) {}

FluidRenderer::~FluidRenderer() = default;

void FluidRenderer::Render(const ViewParams& view, const ParticleBuffer& particles,
                           GLuint scene_color, GLuint scene_depth, GLuint target_framebuffer,
                           const FluidStyle& style) {
  Impl& r = *impl_;
  if (view.width <= 0 || view.height <= 0) return;
  r.Resize(view.width, view.height);

  const bool has_particles = particles.count > 0 && particles.vertex_array != 0;
  const float radius = std::max(particles.radius, 1e-6f);  // divided by in the shaders
  const float near_far[2] = {view.near_plane, view.far_plane};
  const float no_fluid[4] = {0.0f, 0.0f, 0.0f, 0.0f};
  const float far_depth = 1.0f;

  glDisable(GL_BLEND);
  glDisable(GL_CULL_FACE);
  glDisable(GL_SCISSOR_TEST);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, scene_depth);

  // 1. Depth of the nearest sphere surface.
  glBindFramebuffer(GL_FRAMEBUFFER, r.depth_a_fbo.get());
  glViewport(0, 0, r.width, r.height);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDepthMask(GL_TRUE);
  glClearBufferfv(GL_COLOR, 0, no_fluid);
  glClearBufferfv(GL_DEPTH, 0, &far_depth);
  if (has_particles) {
    glUseProgram(r.depth_program.get());
    SetMatrix(Uniform(r.depth_program, "view"), view.view);
    SetMatrix(Uniform(r.depth_program, "projection"), view.projection);
    glUniform1f(Uniform(r.depth_program, "radius"), radius);
    glUniform1i(Uniform(r.depth_program, "scene_depth"), 0);
    glBindVertexArray(particles.vertex_array);
    glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, particles.count);
  }
  glDisable(GL_DEPTH_TEST);

  // 2. Thickness, summed over every sphere the view ray crosses.
  glBindFramebuffer(GL_FRAMEBUFFER, r.thickness_fbo.get());
  glViewport(0, 0, r.thickness_width(), r.thickness_height());
  glClearBufferfv(GL_COLOR, 0, no_fluid);
  if (has_particles) {
    glEnable(GL_BLEND);
    glBlendEquation(GL_FUNC_ADD);
    glBlendFunc(GL_ONE, GL_ONE);
    glUseProgram(r.thickness_program.get());
    SetMatrix(Uniform(r.thickness_program, "view"), view.view);
    SetMatrix(Uniform(r.thickness_program, "projection"), view.projection);
    glUniform1f(Uniform(r.thickness_program, "radius"), radius);
    glUniform1f(Uniform(r.thickness_program, "thickness_per_particle"),
                style.thickness_per_particle);
    glUniform1i(Uniform(r.thickness_program, "scene_depth"), 0);
    glUniform2f(Uniform(r.thickness_program, "scene_scale"),
                float(r.width) / float(r.thickness_width()),
                float(r.height) / float(r.thickness_height()));
    glUniform2fv(Uniform(r.thickness_program, "near_far"), 1, near_far);
    glBindVertexArray(particles.vertex_array);
    glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, particles.count);
    glDisable(GL_BLEND);
  }

  // 3. Bilateral smoothing of the depth: depth_a -> depth_b (horizontal) -> depth_a (vertical).
  glBindVertexArray(r.empty_vao.get());
  glViewport(0, 0, r.width, r.height);
  if (has_particles && style.smoothing_iterations > 0) {
    glUseProgram(r.filter_program.get());
    glUniform1i(Uniform(r.filter_program, "depth"), 0);
    glUniform1f(Uniform(r.filter_program, "world_radius"), style.filter_radius_particles * radius);
    // A length L at eye depth z spans L * P11 / z in NDC, i.e. L * P11 * height / (2 z) pixels.
    glUniform1f(Uniform(r.filter_program, "pixels_per_metre"),
                view.projection(1, 1) * 0.5f * float(r.height));
    glUniform1f(Uniform(r.filter_program, "max_radius"),
                std::clamp(style.filter_radius_pixels, 0.0f, kMaxFilterRadius));
    glUniform1f(Uniform(r.filter_program, "depth_falloff"), kDepthFalloffRadii * radius);
    const GLint direction = Uniform(r.filter_program, "direction");
    for (int i = 0; i < style.smoothing_iterations; ++i) {
      glBindFramebuffer(GL_FRAMEBUFFER, r.depth_b_fbo.get());
      glBindTexture(GL_TEXTURE_2D, r.depth_a.get());
      glUniform2i(direction, 1, 0);
      glDrawArrays(GL_TRIANGLES, 0, 3);
      glBindFramebuffer(GL_FRAMEBUFFER, r.depth_a_fbo.get());
      glBindTexture(GL_TEXTURE_2D, r.depth_b.get());
      glUniform2i(direction, 0, 1);
      glDrawArrays(GL_TRIANGLES, 0, 3);
    }
  }

  // 4. Composite over the scene into the target; every pixel is written.
  glBindFramebuffer(GL_FRAMEBUFFER, target_framebuffer);
  glViewport(0, 0, r.width, r.height);
  glUseProgram(r.composite_program.get());
  const GLuint textures[4] = {r.depth_a.get(), r.thickness.get(), scene_color, scene_depth};
  const char* names[4] = {"fluid_depth", "thickness", "scene_color", "scene_depth"};
  for (int unit = 0; unit < 4; ++unit) {
    glActiveTexture(GLenum(GL_TEXTURE0 + unit));
    glBindTexture(GL_TEXTURE_2D, textures[unit]);
    glUniform1i(Uniform(r.composite_program, names[unit]), unit);
  }
  SetMatrix(Uniform(r.composite_program, "inverse_projection"), view.projection.inverse());
  // The view matrix's rotation is orthonormal: its transpose turns view directions back into
  // world directions.
  const Eigen::Matrix3f view_to_world = view.view.topLeftCorner<3, 3>().transpose();
  glUniformMatrix3fv(Uniform(r.composite_program, "view_to_world"), 1, GL_FALSE,
                     view_to_world.data());
  glUniform3fv(Uniform(r.composite_program, "absorption"), 1, style.absorption);
  glUniform3fv(Uniform(r.composite_program, "water_color"), 1, style.water_color);
  glUniform1f(Uniform(r.composite_program, "refraction_pixels"), style.refraction_pixels);
  glUniform1f(Uniform(r.composite_program, "radius"), radius);
  glUniform2fv(Uniform(r.composite_program, "near_far"), 1, near_far);
  glDrawArrays(GL_TRIANGLES, 0, 3);

  // Leave the state the caller expects: drawing into the target over the full viewport with
  // depth testing on and blending off, nothing bound.
  for (int unit = 3; unit >= 0; --unit) {
    glActiveTexture(GLenum(GL_TEXTURE0 + unit));
    glBindTexture(GL_TEXTURE_2D, 0);
  }
  glBindVertexArray(0);
  glUseProgram(0);
  glBlendFunc(GL_ONE, GL_ZERO);
  glDisable(GL_BLEND);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDepthMask(GL_TRUE);
  glBindFramebuffer(GL_FRAMEBUFFER, target_framebuffer);
  glViewport(0, 0, view.width, view.height);
}

}  // namespace dysa::viewer
