#include "solvers/physical/boundary_particles.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>

#include "dysa/core/kernels.h"

namespace dysa {
namespace {

// Count and step of a lattice of about `spacing` over [lo, hi]: points lo + (k + 1/2) step.
struct Axis {
  int n;
  double step;
};
Axis LatticeAxis(double lo, double hi, double spacing) {
  const int n = std::max(1, int(std::lround((hi - lo) / spacing)));
  return {n, (hi - lo) / n};
}

template <class Keep>
void SampleLattice(const Aabb& box, double spacing, Keep&& keep, std::vector<Vec3>& out) {
  Axis axes[3];
  for (int a = 0; a < 3; ++a) axes[a] = LatticeAxis(box.min[a], box.max[a], spacing);
  for (int z = 0; z < axes[2].n; ++z) {
    for (int y = 0; y < axes[1].n; ++y) {
      for (int x = 0; x < axes[0].n; ++x) {
        const Vec3d p = box.min + Vec3d((x + 0.5) * axes[0].step, (y + 0.5) * axes[1].step,
                                        (z + 0.5) * axes[2].step);
        if (keep(p)) out.push_back(p.cast<Real>());
      }
    }
  }
}

}  // namespace

void SampleDomainWalls(const Aabb& domain, const Periodicity& periodic, double spacing, int layers,
                       std::vector<Vec3>& out, std::vector<Vec3>* fluid_side) {
  const double depth = layers * spacing;
  // No wall across a periodic axis: the lattice is not grown there, and a point's distance to
  // the walls counts the other axes only.
  Vec3d grow;
  for (int a = 0; a < 3; ++a) grow[a] = periodic[a] ? 0.0 : depth;
  const Aabb outer{domain.min - grow, domain.max + grow};
  SampleLattice(
      outer, spacing, [&](const Vec3d& p) { return !domain.Contains(p); }, out);
  if (fluid_side == nullptr) return;
  SampleLattice(
      domain, spacing,
      [&](const Vec3d& p) {
        double nearest = std::numeric_limits<double>::infinity();
        for (int a = 0; a < 3; ++a) {
          if (!periodic[a])
            nearest = std::min({nearest, p[a] - domain.min[a], domain.max[a] - p[a]});
        }
        return nearest < depth;
      },
      *fluid_side);
}

void SampleBox(const Aabb& box, double spacing, int layers, std::vector<Vec3>& out,
               std::vector<Vec3>* fluid_side, int fluid_side_layers) {
  const double depth = layers * spacing;
  SampleLattice(
      box, spacing,
      [&](const Vec3d& p) {
        return std::min((p - box.min).minCoeff(), (box.max - p).minCoeff()) < depth;
      },
      out);
  if (fluid_side == nullptr) return;
  const Vec3d grow = Vec3d::Constant(std::min(layers, fluid_side_layers) * spacing);
  SampleLattice(
      Aabb{box.min - grow, box.max + grow}, spacing,
      [&](const Vec3d& p) { return !box.Contains(p); }, *fluid_side);
}

namespace {

// A Fibonacci spiral of about 4 pi r^2 / d^2 points on the sphere of radius r.
void SampleShell(const Vec3d& center, double r, double spacing, std::vector<Vec3>& out) {
  const double golden_angle = std::numbers::pi * (3 - std::sqrt(5.0));
  const int n = std::max(4, int(std::lround(4 * std::numbers::pi * r * r / (spacing * spacing))));
  for (int i = 0; i < n; ++i) {
    const double y = 1 - 2 * (i + 0.5) / n;
    const double ring = std::sqrt(std::max(0.0, 1 - y * y));
    const double phi = golden_angle * i;
    out.push_back((center + r * Vec3d(ring * std::cos(phi), y, ring * std::sin(phi))).cast<Real>());
  }
}

}  // namespace

void SampleSphere(const SphereObstacle& sphere, double spacing, int layers, std::vector<Vec3>& out,
                  std::vector<Vec3>* fluid_side, int fluid_side_layers) {
  bool reached_centre = false;
  for (int k = 0; k < layers; ++k) {
    const double r = sphere.radius - (k + 0.5) * spacing;
    if (r < 0.5 * spacing) {
      reached_centre = true;
      break;
    }
    SampleShell(sphere.center, r, spacing, out);
  }
  if (reached_centre) out.push_back(sphere.center.cast<Real>());
  if (fluid_side == nullptr) return;
  for (int k = 0; k < std::min(layers, fluid_side_layers); ++k) {
    SampleShell(sphere.center, sphere.radius + (k + 0.5) * spacing, spacing, *fluid_side);
  }
}

int BoundaryParticles::LayersFor(double support, double spacing) {
  // A layer k lies d/2 + k d behind the surface; a fluid particle on the surface reaches the
  // layers with k < support / d - 1/2. The ceiling of support / d keeps one layer in hand for
  // fluid pressed against the wall, as the two layers of support 2 d did.
  return std::max(2, int(std::ceil(support / spacing - 1e-9)));
}

BoundaryParticles::BoundaryParticles(const Model& model, double spacing, double support) {
  std::vector<Vec3> points;
  std::vector<Vec3> fluid_side;
  const int layers = LayersFor(support, spacing);
  SampleDomainWalls(model.domain, model.periodic, spacing, layers, points, &fluid_side);
  // A wall sample is no-slip when it lies beyond the domain across a no-slip axis (an edge's or
  // corner's samples lie beyond two or three walls: no-slip if any of them is).
  std::vector<uint8_t> no_slip(points.size(), 0);
  for (size_t k = 0; k < points.size(); ++k) {
    for (int a = 0; a < 3; ++a) {
      const double x = points[k][a];
      if (model.no_slip[a] && (x < model.domain.min[a] || x > model.domain.max[a])) no_slip[k] = 1;
    }
  }
  // Obstacles are filled: a particle that gets past the outer layers (a thin splash has too
  // little density for any pressure) is still pushed out, instead of being trapped in a
  // hollow shell.
  const size_t wall_samples = points.size();
  std::vector<size_t> obstacle_end;  // one past each obstacle's last sample
  for (const BoxObstacle& b : model.boxes) {
    SampleBox(b.box, spacing, kSolid, points, &fluid_side, layers);
    obstacle_end.push_back(points.size());
  }
  for (const SphereObstacle& s : model.spheres) {
    SampleSphere(s, spacing, kSolid, points, &fluid_side, layers);
    obstacle_end.push_back(points.size());
  }
  const bool moving = std::any_of(model.boxes.begin(), model.boxes.end(),
                                  [](const BoxObstacle& b) { return b.motion.moving(); }) ||
                      std::any_of(model.spheres.begin(), model.spheres.end(),
                                  [](const SphereObstacle& s) { return s.motion.moving(); });
  if (moving) {
    rest_position_ = points;
    obstacle_.assign(points.size(), -1);
    size_t begin = wall_samples;
    for (size_t o = 0; o < obstacle_end.size(); ++o) {
      std::fill(obstacle_.begin() + begin, obstacle_.begin() + obstacle_end[o], int32_t(o));
      begin = obstacle_end[o];
    }
  }

  // The same cells as the fluid's grid: points outside the domain fall into its border cells,
  // which the grid's neighbour query covers exactly (neighbor_grid.h).
  grid_.Configure(model.domain, Real(support), model.periodic, model.grid_cells_per_support);
  grid_.Sort(points);
  const size_t n = points.size();
  no_slip.resize(n, 0);  // the obstacles' samples are free-slip
  no_slip_.resize(n);
  for (size_t k = 0; k < n; ++k) no_slip_[k] = no_slip[grid_.order()[k]];
  volume_.resize(n);
  const Real* xs = grid_.xs().data();
  const Real* ys = grid_.ys().data();
  const Real* zs = grid_.zs().data();
  NeighborGrid fluid_grid;
  fluid_grid.Configure(model.domain, Real(support), model.periodic, model.grid_cells_per_support);
  fluid_grid.Sort(fluid_side);
  const Real* fxs = fluid_grid.xs().data();
  const Real* fys = fluid_grid.ys().data();
  const Real* fzs = fluid_grid.zs().data();
  const PhysicalKernel<Real> kernel{model.kernel_kind, Real(support)};
  auto kernel_sum = [&](const NeighborGrid& grid, const Real* px, const Real* py, const Real* pz,
                        const Eigen::Vector3i& cell, const Vec3& x) {
    double sum = 0;
    grid.ForEachNeighborRun(cell, [&](uint32_t begin, uint32_t end, const Vec3& shift) {
      const Vec3 q = x + shift;
      for (uint32_t k = begin; k < end; ++k) {
        const Real dx = px[k] - q.x(), dy = py[k] - q.y(), dz = pz[k] - q.z();
        sum += double(kernel.W(std::sqrt(dx * dx + dy * dy + dz * dz)));
      }
    });
    return sum;
  };
  // Eq. (4), V_b = 1 / sum_k W_bk, with the sum completed by the fluid at rest on the other side
  // of the surface (fluid_side: the fluid's lattice continued `layers` deep). The boundary's own
  // sum alone lacks that side and inflates V_b: behind a flat wall two boundary layers would
  // then make a fluid lattice at rest 2.6% too dense at the wall, which at c0 = 10 sqrt(g H)
  // is three times the hydrostatic pressure; completed, a flat wall weighs exactly like the
  // fluid it replaces (V_b = d^3: eq. (4) times the lattice's density moment, which the
  // solvers divide their summation densities by), and a curved or sparser sampling still
  // weighs correctly.
  // In double: computed once, from sums of a few dozen terms.
#pragma omp parallel for schedule(static)
  for (int64_t b = 0; b < int64_t(n); ++b) {
    const Eigen::Vector3i cell = grid_.SortedCell(uint32_t(b));
    const Vec3 x(xs[b], ys[b], zs[b]);
    const double sum =
        kernel_sum(grid_, xs, ys, zs, cell, x) + kernel_sum(fluid_grid, fxs, fys, fzs, cell, x);
    volume_[b] = Real(model.density_moment / sum);  // sum >= W(0) > 0: b counts itself
  }
  padded_volume_.assign(n + NeighborGrid::kPadding, Real(0));
  std::copy(volume_.begin(), volume_.end(), padded_volume_.begin());
  if (moving) {
    // Back into sampling order, which MoveObstacles sorts from each step.
    rest_volume_.resize(n);
    rest_no_slip_.resize(n);
    for (size_t k = 0; k < n; ++k) {
      rest_volume_[grid_.order()[k]] = volume_[k];
      rest_no_slip_[grid_.order()[k]] = no_slip_[k];
    }
    velocity_.assign(n, Vec3::Zero());
  }
}

void BoundaryParticles::MoveObstacles(std::span<const Vec3d> displacement,
                                      std::span<const Vec3> velocity) {
  const size_t n = rest_position_.size();
  position_scratch_.resize(n);
  // The rest position in float plus the displacement in float: the same sum for every sample of
  // an obstacle, so it moves rigidly (to float rounding of each coordinate).
  std::vector<Vec3> offset(displacement.size());
  for (size_t o = 0; o < displacement.size(); ++o) offset[o] = displacement[o].cast<Real>();
#pragma omp parallel for schedule(static)
  for (int64_t k = 0; k < int64_t(n); ++k) {
    const int32_t o = obstacle_[k];
    position_scratch_[k] = o < 0 ? rest_position_[k] : Vec3(rest_position_[k] + offset[o]);
  }
  grid_.Sort(position_scratch_);
  const auto order = grid_.order();
#pragma omp parallel for schedule(static)
  for (int64_t k = 0; k < int64_t(n); ++k) {
    const uint32_t from = order[k];
    const int32_t o = obstacle_[from];
    volume_[k] = rest_volume_[from];
    padded_volume_[k] = rest_volume_[from];
    no_slip_[k] = rest_no_slip_[from];
    velocity_[k] = o < 0 ? Vec3::Zero() : velocity[o];
  }
}

}  // namespace dysa
