// The box_force probe (probes.h, BoxForceOn; probe_stages.h): the fluid's pressure force on a
// box obstacle as the integral of the wall pressure over its faces,
//
//   F = - sum over the six faces f, sum over the samples s of f:  p_s n_f dA_f,
//
// with n_f the face's outward normal (into the fluid), p_s the reading of a wall_pressure probe
// at the sample (the same sensor model as P1-P8 of SPHERIC Test 2) and dA_f the area of the
// sample's patch. Each face is cut into nu x nv equal patches of side at most the patch spacing
// (default: the kernel's support) and sampled at their centres (the midpoint rule: exact for the
// hydrostatic pressure, which is linear along a face). A face against a wall, or the floor, has no
// fluid on its side and adds nothing. What it leaves out: the viscous stress (the skin friction of
// a flow at a Reynolds number of 1e5-1e6 is of the order of 1e-3 of its dynamic pressure) and the
// momentum of particles that the solvers' wall contact stops without a pressure (docs/solvers.md).
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "probe_stages.h"
#include "solvers/physical/physical_passes.h"

namespace dysa {

namespace {

// At most this many patches along a face's edge, so that a box far larger than the spacing
// still costs a bounded finish (then the patches are larger than the spacing).
constexpr int kMaxPatchesPerEdge = 1000;

// The patch side of a probe: its own, else the kernel's support (the pressure field is a kernel
// average over that width already, so finer patches resolve nothing more of it).
double SampleSpacing(double spacing, const Model& model) {
  return spacing > 0 ? spacing : model.kernel_support;
}

// One face of the box: the axis a of its normal, the side (-1 or +1) it faces, its corner at the
// smallest u and v (u, v the next axes after a), and its patches.
struct Face {
  int a = 0, u = 1, v = 2;
  double side = 1;
  Vec3d corner = Vec3d::Zero();  // m
  int nu = 1, nv = 1;            // patches along u and v
  double du = 0, dv = 0;         // m, a patch's sides
};

Face FaceOf(const Aabb& box, int a, double side, double spacing) {
  Face f;
  f.a = a;
  f.u = (a + 1) % 3;
  f.v = (a + 2) % 3;
  f.side = side;
  f.corner[a] = side < 0 ? box.min[a] : box.max[a];
  f.corner[f.u] = box.min[f.u];
  f.corner[f.v] = box.min[f.v];
  const double len_u = box.max[f.u] - box.min[f.u], len_v = box.max[f.v] - box.min[f.v];
  f.nu = std::clamp(int(std::ceil(len_u / spacing)), 1, kMaxPatchesPerEdge);
  f.nv = std::clamp(int(std::ceil(len_v / spacing)), 1, kMaxPatchesPerEdge);
  f.du = len_u / f.nu;
  f.dv = len_v / f.nv;
  return f;
}

// The patches [lo, hi] along one edge whose centres (k + 1/2) step lie within `reach` of
// `coordinate`.
void PatchRange(double coordinate, double reach, double step, int count, int& lo, int& hi) {
  lo = std::max(0, int(std::ceil((coordinate - reach) / step - 0.5)));
  hi = std::min(count - 1, int(std::floor((coordinate + reach) / step - 0.5)));
}

// sum over the face's patches of p dA, N. Each candidate is added to the patches within the
// support of it (on the face's side of its plane), candidates in their order, so each patch
// sums exactly what a wall_pressure probe at its centre sums, in the same order.
double PressureTimesArea(std::span<const ProbeCandidate> candidates, const Model& model,
                         const Face& f, double time) {
  const PhysicalKernel<double> kernel = model.Kernel<double>();
  const double g = physical::GravityAt(model.params, time);  // along +y
  const double support = model.kernel_support;
  Vec3d normal = Vec3d::Zero();
  normal[f.a] = f.side;
  std::vector<WallPressureSum> patches(size_t(f.nu) * size_t(f.nv));
  for (const ProbeCandidate& c : candidates) {
    const Vec3d d =
        model.MinimumImage(Vec3d(Vec3d(double(c.x), double(c.y), double(c.z)) - f.corner));
    const double out = d[f.a] * f.side;  // from the face's plane, on its side
    if (out < 0 || out > support) continue;
    // Along the face the kernel reaches sqrt(support^2 - out^2); a hair more against the
    // rounding of the range (beyond the support W is 0, so a patch too many adds nothing).
    const double reach = std::sqrt(support * support - out * out) * (1 + 1e-9) + 1e-12;
    int i_lo, i_hi, j_lo, j_hi;
    PatchRange(d[f.u], reach, f.du, f.nu, i_lo, i_hi);
    PatchRange(d[f.v], reach, f.dv, f.nv, j_lo, j_hi);
    for (int i = i_lo; i <= i_hi; ++i) {
      for (int j = j_lo; j <= j_hi; ++j) {
        Vec3d centre = f.corner;
        centre[f.u] += (i + 0.5) * f.du;
        centre[f.v] += (j + 0.5) * f.dv;
        patches[size_t(i) * size_t(f.nv) + size_t(j)].Add(c, model, kernel, g, centre, normal);
      }
    }
  }
  double sum = 0;
  for (const WallPressureSum& patch : patches) sum += patch.Reading() * (f.du * f.dv);
  return sum;
}

}  // namespace

Aabb ProbeBoxAt(const ProbeSpec& probe, const Model& model, double time) {
  const BoxObstacle& obstacle = model.boxes.at(size_t(probe.box));
  const Vec3d shift = obstacle.motion.DisplacementAt(time);
  return Aabb{obstacle.box.min + shift, obstacle.box.max + shift};
}

Vec3d BoxForceFrom(std::span<const ProbeCandidate> candidates, const Model& model, const Aabb& box,
                   double spacing, double time) {
  const double ds = SampleSpacing(spacing, model);
  // The six faces in a fixed order (x-, x+, y-, y+, z-, z+), each on its own thread where
  // there are several: each face's sum is one thread's, so the force does not depend on them.
  std::array<double, 6> face_sums{};
#pragma omp parallel for schedule(dynamic)
  for (int k = 0; k < 6; ++k) {
    face_sums[size_t(k)] =
        PressureTimesArea(candidates, model, FaceOf(box, k / 2, k % 2 ? 1.0 : -1.0, ds), time);
  }
  Vec3d force = Vec3d::Zero();
  for (int k = 0; k < 6; ++k) force[k / 2] -= (k % 2 ? 1.0 : -1.0) * face_sums[size_t(k)];
  return force;
}

}  // namespace dysa
