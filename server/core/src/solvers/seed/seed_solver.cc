#include "solvers/seed/seed_solver.h"

#include <cmath>
#include <cstdint>
#include <string>

#include "dysa/core/kernels.h"
#include "simd.h"
#include "solvers/domain_walls.h"

namespace dysa::seed {
namespace {

// A unit direction for two coincident particles: the pair (i, j) gets a direction from a hash
// of their ids, and (j, i) the opposite one, so the pair still exerts equal and opposite forces
// and a cluster of coincident particles spreads in 3D instead of moving together.
Vec3 CoincidentDirection(uint32_t id_i, uint32_t id_j) {
  const uint32_t lo = id_i < id_j ? id_i : id_j;
  const uint32_t hi = id_i < id_j ? id_j : id_i;
  uint64_t h = (uint64_t{lo} << 32 | hi) * 0x9E3779B97F4A7C15ull;
  h ^= h >> 29;
  h *= 0xBF58476D1CE4E5B9ull;
  h ^= h >> 32;
  Vec3 d(Real(int(h & 0xFFFF)) - Real(32767.5), Real(int((h >> 16) & 0xFFFF)) - Real(32767.5),
         Real(int((h >> 32) & 0xFFFF)) - Real(32767.5));
  d.normalize();
  return id_i < id_j ? d : Vec3(-d);
}

}  // namespace

void ApplyExternalForces(const Model& model, SeedData& data, State& state) {
  ParticleArrays& p = state.particles;
  const Vec3 dv(0, Real(model.params.gravity * model.dt), 0);
  const int64_t n = static_cast<int64_t>(p.size());
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    p.velocity[i] += dv;
    data.predicted[i] = p.position[i] + p.velocity[i] * kPredictionLookahead;
  }
}

using simd::MaskV;
using simd::RealV;

// Vector values are created inside the OpenMP loops, never shared into them: GCC 12 does not
// keep the 32-byte alignment of vectors in the block it passes to the outlined parallel
// function, and aligned AVX loads from it fault.

// Loads candidates [j, j + 8) of a run and returns the masked squared distances' ingredients.
struct CandidateBlock {
  RealV dx, dy, dz, r2;
  MaskV in_run;
};

// The query point of a run: particle i's position moved by the run's periodic shift
// (NeighborGrid::ForEachNeighborRun; zero without periodic axes, which leaves it bit-identical).
struct Query {
  RealV x, y, z;
  Query(RealV xi, RealV yi, RealV zi, const Vec3& shift)
      : x(xi + shift.x()), y(yi + shift.y()), z(zi + shift.z()) {}
};

inline CandidateBlock LoadCandidates(const Real* xs, const Real* ys, const Real* zs, const Query& q,
                                     uint32_t j, uint32_t end) {
  CandidateBlock c;
  c.dx = simd::Load(xs + j) - q.x;
  c.dy = simd::Load(ys + j) - q.y;
  c.dz = simd::Load(zs + j) - q.z;
  c.r2 = c.dx * c.dx + c.dy * c.dy + c.dz * c.dz;
  c.in_run = simd::InRun(j, end);
  return c;
}

// Copies `values` into `padded` (n + kPadding entries, the tail zero) so vector loads at the end
// of a run stay inside the buffer.
template <class F>
Real* PaddedArray(std::vector<Real>& storage, size_t slot, size_t n, F&& value_of) {
  const size_t stride = n + NeighborGrid::kPadding;
  Real* out = storage.data() + slot * stride;
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < int64_t(n); ++i) out[i] = value_of(i);
  std::fill(out + n, out + stride, Real(0));
  return out;
}

template <bool kNear>
void ComputeDensities(const Model& model, SeedData& data, State& state) {
  ParticleArrays& p = state.particles;
  const SeedKernelFactors<Real> k(Real(model.params.smoothing_radius));
  const Real mass = Real(model.params.particle_mass);
  const Real rho0 = Real(model.params.target_density);
  const Real stiffness = Real(model.params.pressure_multiplier);
  const Real near_stiffness = Real(model.params.near_pressure_multiplier);
  const NeighborGrid& grid = state.grid;
  const Real* xs = grid.xs().data();
  const Real* ys = grid.ys().data();
  const Real* zs = grid.zs().data();
  const int64_t n = static_cast<int64_t>(p.size());
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    const RealV h = simd::Broadcast(k.h);
    const RealV h2 = simd::Broadcast(k.h2);
    const RealV xi = simd::Broadcast(xs[i]), yi = simd::Broadcast(ys[i]),
                zi = simd::Broadcast(zs[i]);
    RealV sum2{};  // sum of (h - r)^2
    RealV sum3{};  // sum of (h - r)^3
    grid.ForEachNeighborRun(
        grid.SortedCell(uint32_t(i)), [&](uint32_t begin, uint32_t end, const Vec3& shift) {
          const Query q_i(xi, yi, zi, shift);
          for (uint32_t j = begin; j < end; j += simd::kLanes) {
            const CandidateBlock c = LoadCandidates(xs, ys, zs, q_i, j, end);
            const RealV q = simd::Select(c.in_run & (c.r2 < h2), h - simd::Sqrt(c.r2), RealV{});
            sum2 += q * q;
            if constexpr (kNear) sum3 += q * q * q;
          }
        });
    const Real rho = mass * k.spiky2 * simd::Sum(sum2);
    p.density[i] = rho;
    p.pressure[i] = (rho - rho0) * stiffness;
    if constexpr (kNear) {
      const Real rho_near = mass * k.spiky3 * simd::Sum(sum3);
      data.near_density[i] = rho_near;
      data.near_pressure[i] = rho_near * near_stiffness;
    }
  }
}

// a_i = m / rho_i * sum_j [dW2(r_ij)/dr (p_i + p_j) + dW3(r_ij)/dr (pn_i + pn_j)] / (2 rho_j)
//       * (x_j - x_i) / r_ij
// with W2 = spiky^2, W3 = spiky^3, p the pressure and pn the near pressure. Both terms carry
// 1 / (rho_i rho_j), symmetric in i and j, so the pair forces are equal and opposite and
// momentum is conserved. (The thesis's shader divides the near term by the neighbour's near
// density instead, which breaks that symmetry: total momentum drifts by ~1e-3 per 100 steps.)
// The factors (p_i + p_j) / (2 rho_j) are evaluated as p_i * half_inv_rho_j + half_p_over_rho_j.
template <bool kNear>
void ApplyPressureForces(const Model& model, SeedData& data, State& state) {
  ParticleArrays& p = state.particles;
  const SeedKernelFactors<Real> k(Real(model.params.smoothing_radius));
  const Real mass_dt = Real(model.params.particle_mass * model.dt);
  const NeighborGrid& grid = state.grid;
  const Real* xs = grid.xs().data();
  const Real* ys = grid.ys().data();
  const Real* zs = grid.zs().data();
  const uint32_t* id = p.id.data();
  const size_t n = p.size();

  state.real_scratch.resize(3 * (n + NeighborGrid::kPadding));
  std::vector<Real>& scratch = state.real_scratch;
  const Real* half_inv_rho =
      PaddedArray(scratch, 0, n, [&](int64_t j) { return Real(0.5) / p.density[j]; });
  const Real* half_p_over_rho = PaddedArray(
      scratch, 1, n, [&](int64_t j) { return Real(0.5) * p.pressure[j] / p.density[j]; });
  const Real* half_pn_over_rho = half_p_over_rho;
  if constexpr (kNear) {
    half_pn_over_rho = PaddedArray(
        scratch, 2, n, [&](int64_t j) { return Real(0.5) * data.near_pressure[j] / p.density[j]; });
  }

#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < int64_t(n); ++i) {
    const RealV h = simd::Broadcast(k.h);
    const RealV h2 = simd::Broadcast(k.h2);
    const RealV grad2 = simd::Broadcast(k.spiky2_grad);
    const RealV grad3 = simd::Broadcast(k.spiky3_grad);
    const RealV xi = simd::Broadcast(xs[i]), yi = simd::Broadcast(ys[i]),
                zi = simd::Broadcast(zs[i]);
    const RealV pi = simd::Broadcast(p.pressure[i]);
    const RealV pni = simd::Broadcast(kNear ? data.near_pressure[i] : Real(0));
    RealV fx{}, fy{}, fz{};
    MaskV coincident{};  // candidates at distance 0, i itself included
    grid.ForEachNeighborRun(
        grid.SortedCell(uint32_t(i)), [&](uint32_t begin, uint32_t end, const Vec3& shift) {
          const Query q_i(xi, yi, zi, shift);
          for (uint32_t j = begin; j < end; j += simd::kLanes) {
            const CandidateBlock c = LoadCandidates(xs, ys, zs, q_i, j, end);
            const MaskV inside = c.in_run & (c.r2 < h2) & (c.r2 > RealV{});
            coincident -= c.in_run & (c.r2 == RealV{});  // a true lane is -1
            const RealV r = simd::Sqrt(c.r2);
            const RealV q = simd::Select(inside, h - r, RealV{});
            const RealV inv_r = simd::Select(inside, Real(1) / r, RealV{});
            // -dW/dr times the shared pressure over rho_j; the force pushes i away from j.
            RealV magnitude =
                grad2 * q * (pi * simd::Load(half_inv_rho + j) + simd::Load(half_p_over_rho + j));
            if constexpr (kNear) {
              magnitude += grad3 * q * q *
                           (pni * simd::Load(half_inv_rho + j) + simd::Load(half_pn_over_rho + j));
            }
            const RealV s = simd::Select(inside, magnitude * inv_r, RealV{});
            fx -= c.dx * s;
            fy -= c.dy * s;
            fz -= c.dz * s;
          }
        });
    Vec3 force(simd::Sum(fx), simd::Sum(fy), simd::Sum(fz));
    int32_t zero_distance = 0;
    for (int l = 0; l < simd::kLanes; ++l) zero_distance += coincident[l];
    if (zero_distance > 1) {
      // Rare: particles exactly on top of each other get a pair-specific direction.
      const Real pi_s = p.pressure[i];
      const Real pni_s = kNear ? data.near_pressure[i] : Real(0);
      grid.ForEachNeighborRun(
          grid.SortedCell(uint32_t(i)), [&](uint32_t begin, uint32_t end, const Vec3& shift) {
            for (uint32_t j = begin; j < end; ++j) {
              // The same test as the vector loop's r2 == 0 (across a periodic seam too).
              if (j == uint32_t(i) || xs[j] - (xs[i] + shift.x()) != 0 ||
                  ys[j] - (ys[i] + shift.y()) != 0 || zs[j] - (zs[i] + shift.z()) != 0) {
                continue;
              }
              Real magnitude = k.spiky2_grad * k.h * (pi_s * half_inv_rho[j] + half_p_over_rho[j]);
              if constexpr (kNear) {
                magnitude +=
                    k.spiky3_grad * k.h * k.h * (pni_s * half_inv_rho[j] + half_pn_over_rho[j]);
              }
              force -= CoincidentDirection(id[i], id[j]) * magnitude;
            }
          });
    }
    p.velocity[i] += force * (mass_dt * 2 * half_inv_rho[i]);
  }
}

// v_i += mu dt sum_j (v_j - v_i) W_poly6(r_ij), reading the velocities from a copy made before
// the pass, so the result does not depend on the order particles are visited.
//
// Stability: the update relaxes v_i toward a weighted mean of its neighbours with the gain
// c_i = mu dt sum_j W_ij. Beyond c_i = 1 it overshoots the mean and the velocities grow without
// bound (explicit diffusion past its step limit), so the gain is capped at 1: the particle then
// takes its neighbours' mean velocity. The cap never acts at the thesis's viscosities.
void ApplyViscosity(const Model& model, State& state) {
  ParticleArrays& p = state.particles;
  const SeedKernelFactors<Real> k(Real(model.params.smoothing_radius));
  const Real scale = Real(model.params.viscosity * model.dt) * k.poly6;
  const NeighborGrid& grid = state.grid;
  const Real* xs = grid.xs().data();
  const Real* ys = grid.ys().data();
  const Real* zs = grid.zs().data();
  const size_t n = p.size();
  state.real_scratch.resize(3 * (n + NeighborGrid::kPadding));
  std::vector<Real>& scratch = state.real_scratch;
  const Real* vx = PaddedArray(scratch, 0, n, [&](int64_t j) { return p.velocity[j].x(); });
  const Real* vy = PaddedArray(scratch, 1, n, [&](int64_t j) { return p.velocity[j].y(); });
  const Real* vz = PaddedArray(scratch, 2, n, [&](int64_t j) { return p.velocity[j].z(); });
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < int64_t(n); ++i) {
    const RealV h2 = simd::Broadcast(k.h2);
    const RealV xi = simd::Broadcast(xs[i]), yi = simd::Broadcast(ys[i]),
                zi = simd::Broadcast(zs[i]);
    const RealV vxi = simd::Broadcast(vx[i]), vyi = simd::Broadcast(vy[i]),
                vzi = simd::Broadcast(vz[i]);
    RealV ax{}, ay{}, az{}, wsum{};
    grid.ForEachNeighborRun(
        grid.SortedCell(uint32_t(i)), [&](uint32_t begin, uint32_t end, const Vec3& shift) {
          const Query q_i(xi, yi, zi, shift);
          for (uint32_t j = begin; j < end; j += simd::kLanes) {
            const CandidateBlock c = LoadCandidates(xs, ys, zs, q_i, j, end);
            const RealV w = simd::Select(c.in_run & (c.r2 < h2), h2 - c.r2, RealV{});
            const RealV w3 = w * w * w;
            ax += (simd::Load(vx + j) - vxi) * w3;
            ay += (simd::Load(vy + j) - vyi) * w3;
            az += (simd::Load(vz + j) - vzi) * w3;
            wsum += w3;
          }
        });
    const Real total = simd::Sum(wsum);
    const Real gain = total * scale > 1 ? 1 / total : scale;
    p.velocity[i] += Vec3(simd::Sum(ax), simd::Sum(ay), simd::Sum(az)) * gain;
  }
}

void IntegrateAndCollideWithWalls(const Model& model, State& state) {
  ParticleArrays& p = state.particles;
  const Real dt = Real(model.dt);
  const Real damping = Real(model.params.collision_damping);
  const int64_t n = static_cast<int64_t>(p.size());
  // The fixed step's CFL limit: a particle that crosses more than a smoothing radius in one step
  // jumps past the neighbours that should have slowed it, and the state blows up (a stiffness,
  // smoothing radius or time step beyond the model's stability limit). Such particles are
  // slowed to h / dt, and the step's warning says how many: bounded instead of garbage. The
  // thesis's scenes stay well below it (about 20 m/s against 45 m/s).
  const Real limit = Real(model.params.smoothing_radius / model.dt);
  int64_t limited = 0;
#pragma omp parallel for schedule(static) reduction(+ : limited)
  for (int64_t i = 0; i < n; ++i) {
    const Real speed2 = p.velocity[i].squaredNorm();
    if (speed2 > limit * limit) {
      p.velocity[i] *= limit / std::sqrt(speed2);
      ++limited;
    }
    p.position[i] += p.velocity[i] * dt;
    CollideWithDomainWalls(model.domain, model.periodic, damping, p.position[i], p.velocity[i]);
  }
  if (limited > 0) state.warning = VelocityLimiterWarning(uint64_t(limited), model, state.step + 1);
}

std::string VelocityLimiterWarning(uint64_t limited, const Model& model, uint64_t step) {
  const Real limit = Real(model.params.smoothing_radius / model.dt);
  return "velocity limiter: " + std::to_string(limited) +
         " particles faster than smoothing_radius / dt = " + std::to_string(limit) +
         " m/s slowed at step " + std::to_string(step) +
         "; the time step is beyond this scene's stability limit (lower time_scale, raise "
         "iterations_per_frame or soften the pressure)";
}

template void ComputeDensities<true>(const Model&, SeedData&, State&);
template void ComputeDensities<false>(const Model&, SeedData&, State&);
template void ApplyPressureForces<true>(const Model&, SeedData&, State&);
template void ApplyPressureForces<false>(const Model&, SeedData&, State&);

void SortParticlesIntoGrid(const Model& model, SeedData& data, State& state) {
  ParticleArrays& p = state.particles;
  state.grid.Configure(model.domain, Real(model.params.smoothing_radius), model.periodic);
  state.grid.Sort(data.predicted);
  const auto order = state.grid.order();
  PermuteInPlace(order, p.position, state.vec3_scratch);
  PermuteInPlace(order, p.velocity, state.vec3_scratch);
  PermuteInPlace(order, data.predicted, state.vec3_scratch);
  PermuteInPlace(order, p.id, state.index_scratch);
}

namespace {

// An obstacle where the step leaves it: `offset` its displacement at the step's end, `u` its
// mean velocity over the step (both 0 for a static one). The velocity relative to the obstacle
// is reflected, so a moving obstacle throws the particles it meets ahead of it.
void CollideWithSphere(const SphereObstacle& s, const Vec3& offset, const Vec3& u, Real damping,
                       Vec3& x, Vec3& v) {
  const Vec3 c = s.center.cast<Real>() + offset;
  const Real r = Real(s.radius);
  const Vec3 d = x - c;
  const Real dist2 = d.squaredNorm();
  if (dist2 >= r * r) return;
  const Real dist = std::sqrt(dist2);
  const Vec3 n = dist > 0 ? Vec3(d / dist) : Vec3::UnitY();
  x = c + n * r;
  const Real vn = (v - u).dot(n);
  if (vn < 0) v -= (1 + damping) * vn * n;
}

void CollideWithBox(const BoxObstacle& b, const Vec3& offset, const Vec3& u, Real damping, Vec3& x,
                    Vec3& v) {
  const Vec3 lo = b.box.min.cast<Real>() + offset;
  const Vec3 hi = b.box.max.cast<Real>() + offset;
  if (!((x.array() > lo.array()).all() && (x.array() < hi.array()).all())) return;
  // Leave through the nearest face.
  int axis = 0;
  Real best = x[0] - lo[0];
  Real face = lo[0];
  Real outward = -1;
  for (int a = 0; a < 3; ++a) {
    if (x[a] - lo[a] < best) best = x[a] - lo[a], axis = a, face = lo[a], outward = -1;
    if (hi[a] - x[a] < best) best = hi[a] - x[a], axis = a, face = hi[a], outward = 1;
  }
  x[axis] = face;
  const Real vn = v[axis] - u[axis];
  // At rest the bounce is exactly -v damping, a zero's sign included.
  if (vn * outward < 0) v[axis] = u[axis] == 0 ? -vn * damping : u[axis] - vn * damping;
}

}  // namespace

void CollideWithObstacles(const Model& model, State& state) {
  ParticleArrays& p = state.particles;
  const Real damping = Real(model.params.collision_damping);
  const int64_t n = static_cast<int64_t>(p.size());
  // Per obstacle (spheres, then boxes): its displacement at the step's end, where the
  // integrated positions are, and its mean velocity over the step. All 0 for static obstacles.
  const size_t count = model.spheres.size() + model.boxes.size();
  std::vector<Vec3> offset(count, Vec3::Zero()), velocity(count, Vec3::Zero());
  if (model.HasMovingObstacles()) {
    const double t = state.time, dt = state.dt;
    auto frame = [&](const ObstacleMotion& m, size_t k) {
      const Vec3d end = m.DisplacementAt(t + dt);
      offset[k] = end.cast<Real>();
      velocity[k] = ((end - m.DisplacementAt(t)) / dt).cast<Real>();
    };
    for (size_t k = 0; k < model.spheres.size(); ++k) frame(model.spheres[k].motion, k);
    for (size_t k = 0; k < model.boxes.size(); ++k) {
      frame(model.boxes[k].motion, model.spheres.size() + k);
    }
  }
  const size_t spheres = model.spheres.size();
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    for (size_t k = 0; k < spheres; ++k) {
      CollideWithSphere(model.spheres[k], offset[k], velocity[k], damping, p.position[i],
                        p.velocity[i]);
    }
    for (size_t k = 0; k < model.boxes.size(); ++k) {
      CollideWithBox(model.boxes[k], offset[spheres + k], velocity[spheres + k], damping,
                     p.position[i], p.velocity[i]);
    }
  }
}

std::vector<Pass> SeedSolver::BuildPasses(const Model& model) {
  const bool near = model.params.near_pressure_multiplier > 0;
  std::vector<Pass> passes;
  passes.push_back(SolverPass("external_forces", data_, ApplyExternalForces));
  passes.push_back(SolverPass("neighbour_grid", data_, SortParticlesIntoGrid));
  if (near) {
    passes.push_back(SolverPass("density", data_, ComputeDensities<true>));
    passes.push_back(SolverPass("pressure_force", data_, ApplyPressureForces<true>));
  } else {
    passes.push_back(SolverPass("density", data_, ComputeDensities<false>));
    passes.push_back(SolverPass("pressure_force", data_, ApplyPressureForces<false>));
  }
  if (model.params.viscosity > 0) passes.push_back({"viscosity", ApplyViscosity});
  passes.push_back({"integrate", IntegrateAndCollideWithWalls});
  if (model.HasObstacles()) passes.push_back({"obstacles", CollideWithObstacles});
  return passes;
}

void SeedSolver::Reset(size_t particles) {
  // Every array is written by the step before it is read (predicted by external_forces, the
  // near densities by density); zero until then.
  data_.predicted.assign(particles, Vec3::Zero());
  data_.near_density.assign(particles, Real(0));
  data_.near_pressure.assign(particles, Real(0));
}

std::unique_ptr<Solver> CreateSeedSolver() { return std::make_unique<SeedSolver>(); }

}  // namespace dysa::seed
