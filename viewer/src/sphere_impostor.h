// Sphere impostors in GLSL, shared by the particle and fluid renderers: the screen-space quad
// that holds a sphere, and the view ray's intersection with it.
#pragma once

namespace dysa::viewer {

// Sphere impostors: a camera-facing quad per particle in the plane of its centre; each fragment
// intersects its view ray with the true sphere. The quad is made just large enough to hold the
// sphere's outline (fragments are the cost here): from the eye, the sphere fills a cone of
// half-angle a = asin(r / D) around the direction to its centre, which is theta off the view
// axis. In the centre's plane, at distance Z, the cone's far side lies Z tan(theta + a) from
// the axis, e = Z tan(theta + a) - rho beyond the centre (rho = Z tan(theta)); that is the
// largest distance from the centre to any point of the outline, so a square of half-width e
// covers it. Head on, e = r D / sqrt(D^2 - r^2), barely more than r.
//
// ImpostorHalfWidth(c, r): that half-width e for a sphere of radius r centred at c (view space).
inline constexpr const char* kImpostorHalfWidthGlsl = R"(
float ImpostorHalfWidth(vec3 c, float radius) {
  float z = max(-c.z, 1e-6);
  float d2 = dot(c, c);
  float rho = length(c.xy);
  float tan_theta = rho / z;
  float tan_a = radius / sqrt(max(d2 - radius * radius, 1e-12));
  float denominator = 1.0 - tan_theta * tan_a;
  // Beyond 90 degrees (a sphere beside the eye) the outline is unbounded: a large quad.
  float extent = denominator > 0.05 ? z * (tan_theta + tan_a) / denominator - rho : 20.0 * radius;
  return min(extent * 1.01, 20.0 * radius);  // 1%: rounding; 20 r: spheres at the eye
}
)";

// IntersectSphere(d, c, r, t_near, t_far): the ray from the eye (the origin) along the unit
// vector d meets the sphere where |t d - c|^2 = r^2, i.e. t = b -+ sqrt(b^2 - |c|^2 + r^2) with
// b = d.c. Returns false when the ray misses.
inline constexpr const char* kIntersectSphereGlsl = R"(
bool IntersectSphere(vec3 d, vec3 c, float r, out float t_near, out float t_far) {
  float b = dot(d, c);
  float disc = b * b - dot(c, c) + r * r;
  if (disc < 0.0) return false;
  float s = sqrt(disc);
  t_near = b - s;
  t_far = b + s;
  return true;
}
)";

}  // namespace dysa::viewer
