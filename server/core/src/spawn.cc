#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>

#include "dysa/core/simulation.h"
#include "dysa/core/solver.h"

namespace dysa {
namespace {

// SplitMix64 (Steele, Lea, Flood 2014): a tiny generator whose output is the same on every
// platform and standard library, unlike std::uniform_real_distribution.
class SplitMix64 {
 public:
  explicit SplitMix64(uint64_t seed) : state_(seed) {}
  uint64_t Next() {
    uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  // Uniform in [-1, 1).
  double Signed() { return double(Next() >> 11) * 0x1.0p-52 - 1.0; }
  // Uniform in the unit ball, by rejection from the cube (52% acceptance).
  Vec3d InUnitBall() {
    for (;;) {
      const Vec3d v(Signed(), Signed(), Signed());
      if (v.squaredNorm() <= 1.0) return v;
    }
  }

 private:
  uint64_t state_;
};

// Whether a lattice point lies inside an obstacle, or closer than `margin` to one: fluid is not
// spawned inside solids (a particle there would be thrown out by the wall's full pressure in
// one step).
// A moving obstacle is where its motion has it at t = 0. A lattice point exactly `margin` from
// a face (a block that ends flush with an obstacle, its last layer d/2 from it) is kept: the
// bound is a hair under the margin, so rounding in x - box.max cannot drop the layer.
bool InsideObstacle(const Scene& scene, const Vec3d& x, double margin) {
  margin *= 1 - 1e-9;
  for (const SphereObstacle& s : scene.spheres) {
    if ((x - s.center - s.motion.DisplacementAt(0)).norm() < s.radius + margin) return true;
  }
  for (const BoxObstacle& b : scene.boxes) {
    const Vec3d d = b.motion.DisplacementAt(0);
    const Aabb box{b.box.min + d, b.box.max + d};
    const Vec3d outside = (box.min - x).cwiseMax(x - box.max).cwiseMax(0.0);
    if (outside.norm() < margin || box.Contains(x)) return true;
  }
  return false;
}

}  // namespace

uint64_t VisitSpawnedParticles(
    const Scene& scene, const Params& params,
    const std::function<void(uint32_t id, const Vec3& position, const Vec3& velocity)>& visit) {
  const std::vector<Eigen::Vector3i> counts = BlockParticleCounts(scene, params);
  const bool physical = IsPhysicalSolver(scene.solver);
  // Boundary particles of the physical solvers sit on the obstacle's surface: keep the fluid
  // half a spacing away, as from the domain walls.
  const double obstacle_margin = physical ? 0.5 * params.particle_spacing : 0.0;

  uint64_t i = 0;
  for (size_t b = 0; b < scene.fluid_blocks.size(); ++b) {
    const FluidBlock& block = scene.fluid_blocks[b];
    const Eigen::Vector3i n = counts[b];
    const Vec3d center = block.center.value_or(scene.domain.Center());
    const Vec3d size = block.size.value_or(Vec3d::Constant(params.spawn_size));
    // Physical solvers: the lattice of particle_spacing (BlockParticleCounts rejects a block's
    // own count or spacing), and no jitter unless the block asks for it: the seed's default
    // spawn_jitter is in the seed's length scale.
    const std::optional<double> spacing =
        physical ? std::optional<double>(params.particle_spacing) : block.spacing;
    const double jitter = block.jitter.value_or(physical ? 0.0 : params.spawn_jitter);
    const Vec3 velocity = block.velocity.cast<Real>();
    SplitMix64 rng(block.seed);
    // The offset of lattice point k along axis a from the block centre. The lattice step is
    // the one SpawnParticleRadius takes (spawn_test checks that they agree).
    auto offset = [&](int a, int k) {
      if (spacing) return (k - 0.5 * (n[a] - 1)) * *spacing;
      // The thesis's spawner: n points spanning the edge, both ends included.
      return n[a] > 1 ? (double(k) / (n[a] - 1) - 0.5) * size[a] : 0.0;
    };
    for (int x = 0; x < n.x(); ++x) {
      for (int y = 0; y < n.y(); ++y) {
        for (int z = 0; z < n.z(); ++z) {
          Vec3d pos = center + Vec3d(offset(0, x), offset(1, y), offset(2, z));
          if (jitter > 0) pos += rng.InUnitBall() * jitter;
          if (InsideObstacle(scene, pos, obstacle_margin)) continue;
          visit(static_cast<uint32_t>(i), pos.cast<Real>(), velocity);
          ++i;
        }
      }
    }
  }
  return i;
}

void SpawnParticles(const Scene& scene, const Params& params, ParticleArrays& particles) {
  const std::vector<Eigen::Vector3i> counts = BlockParticleCounts(scene, params);
  size_t total = 0;
  for (const Eigen::Vector3i& n : counts) total += size_t(n.x()) * n.y() * n.z();
  particles.Resize(total);
  const uint64_t spawned =
      VisitSpawnedParticles(scene, params, [&](uint32_t id, const Vec3& x, const Vec3& v) {
        particles.id[id] = id;
        particles.position[id] = x;
        particles.velocity[id] = v;
      });
  particles.Resize(spawned);  // less the points inside obstacles
  std::fill(particles.density.begin(), particles.density.end(), Real(0));
  std::fill(particles.pressure.begin(), particles.pressure.end(), Real(0));
}

double SpawnParticleRadius(const Scene& scene, const Params& params) {
  const std::vector<Eigen::Vector3i> counts = BlockParticleCounts(scene, params);
  const bool physical = IsPhysicalSolver(scene.solver);
  double spacing = std::numeric_limits<double>::infinity();
  for (size_t b = 0; b < scene.fluid_blocks.size(); ++b) {
    const FluidBlock& block = scene.fluid_blocks[b];
    const Vec3d size = block.size.value_or(Vec3d::Constant(params.spawn_size));
    for (int a = 0; a < 3; ++a) {
      const int n = counts[b][a];
      if (n < 2) continue;  // one particle: no neighbour along this axis
      spacing = std::min(spacing, physical        ? params.particle_spacing
                                  : block.spacing ? *block.spacing
                                                  : size[a] / (n - 1));
    }
  }
  if (!std::isfinite(spacing)) spacing = params.smoothing_radius;
  return 0.5 * spacing;
}

}  // namespace dysa
