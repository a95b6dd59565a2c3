#include "stress/stress_cases.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>
#include <utility>

#include "dysa/core/params.h"
#include "solvers/seed/seed_solver.h"

namespace dysa::stress {

double KineticEnergy(const Simulation& sim) {
  const ParticleArrays& p = sim.state().particles;
  double sum = 0;
  for (size_t i = 0; i < p.size(); ++i) sum += double(p.velocity[i].squaredNorm());
  return 0.5 * sim.model().particle_mass * sum;
}

double GravityEnergy(const Simulation& sim) {
  const ParticleArrays& p = sim.state().particles;
  const double g = sim.params().gravity;
  const Aabb& domain = sim.model().domain;
  double sum = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    const double y = p.position[i].y();
    sum += g < 0 ? y - domain.min.y() : domain.max.y() - y;
  }
  return sim.model().particle_mass * std::abs(g) * std::max(0.0, sum);
}

double PressureWork(const Simulation& sim) {
  const ParticleArrays& p = sim.state().particles;
  // The seed's near pressure, a pressure of its own (Clavet et al.), counts too.
  const auto* seed = dynamic_cast<const seed::SeedSolver*>(sim.solver());
  const std::vector<Real>* near = seed ? &seed->data().near_pressure : nullptr;
  double sum = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    if (!(p.density[i] > 0)) continue;
    const double near_pressure = near ? std::abs(double((*near)[i])) : 0;
    sum += (std::abs(double(p.pressure[i])) + near_pressure) / double(p.density[i]);
  }
  return sim.model().particle_mass * sum;
}

Scene BaseScene(const SolverInfo& solver) {
  Scene s;
  s.name = "stress";
  s.solver = std::string(solver.name);
  s.domain = Aabb{Vec3d::Constant(-0.5), Vec3d::Constant(0.5)};
  FluidBlock block;
  block.center = Vec3d(0, -0.05, 0);
  block.size = Vec3d::Constant(0.4);
  block.seed = 3;
  if (solver.physical) {
    SetParam(s.params, "gravity", -9.81);
    SetParam(s.params, "particle_spacing", 0.04);
    SetParam(s.params, "speed_of_sound", 20);
    SetParam(s.params, "kinematic_viscosity", 1e-4);
    block.jitter = 0.0;
  } else {
    s.domain = Aabb{Vec3d::Constant(-1.0), Vec3d::Constant(1.0)};
    block.size = Vec3d::Constant(1.0);
    block.particles_per_axis = Eigen::Vector3i::Constant(7);
    block.jitter = 0.01;
  }
  s.fluid_blocks.push_back(block);
  return s;
}

std::vector<Case> Cases(const SolverInfo& solver) {
  const Scene base = BaseScene(solver);
  const bool physical = solver.physical;
  std::vector<Case> cases;
  cases.push_back({"base", base});
  {
    Scene s = base;
    FluidBlock& b = s.fluid_blocks[0];
    if (physical) {
      b.size = Vec3d::Constant(0.04);  // one lattice point
    } else {
      b.particles_per_axis = Eigen::Vector3i::Constant(1);
    }
    cases.push_back({"one_particle", s});
  }
  {
    Scene s = base;
    s.fluid_blocks.clear();
    cases.push_back({"no_particles", s});
  }
  {
    Scene s = base;  // the same block twice: every particle starts on top of another
    s.fluid_blocks[0].jitter = 0.0;
    s.fluid_blocks.push_back(s.fluid_blocks[0]);
    cases.push_back({"coincident_particles", s});
  }
  {
    Scene s = base;  // one particle layer thick
    FluidBlock& b = s.fluid_blocks[0];
    if (physical) {
      b.size = Vec3d(0.8, 0.04, 0.8);
    } else {
      b.size = Vec3d(1.6, 1e-3, 1.6);
      b.particles_per_axis = Eigen::Vector3i(12, 1, 12);
    }
    cases.push_back({"thin_sheet", s});
  }
  {
    // Very dense: eight times the particles in the block. The seed model packs them closer (it
    // starts far above its rest density); a physical solver fills the block at half the spacing
    // (its density is rest density by construction; a start above it is the coincident case).
    Scene s = base;
    if (physical) {
      SetParam(s.params, "particle_spacing", 0.02);
    } else {
      s.fluid_blocks[0].particles_per_axis = Eigen::Vector3i::Constant(14);
    }
    cases.push_back({"dense_block", s});
  }
  {
    Scene s = base;  // thrown at the floor and a wall
    s.fluid_blocks[0].velocity = physical ? Vec3d(15, -15, 0) : Vec3d(30, -40, 0);
    cases.push_back({"high_speed_impact", s});
  }
  {
    Scene s = base;  // obstacles placed inside the fluid
    s.spheres.push_back(SphereObstacle{*base.fluid_blocks[0].center, physical ? 0.12 : 0.3, {}});
    const Vec3d box_center = *base.fluid_blocks[0].center + Vec3d(physical ? 0.15 : 0.35, 0, 0);
    const Vec3d half = Vec3d::Constant(physical ? 0.05 : 0.125);
    const BoxObstacle box{Aabb{box_center - half, box_center + half}, {}};
    s.boxes.push_back(box);
    cases.push_back({"obstacles_inside_fluid", s});
  }
  {
    Scene s = base;  // the time step at the stability limit, then beyond it
    if (physical) {
      SetParam(s.params, "cfl_factor", 0.4);
      SetParam(s.params, "max_time_step", 1.0);
      cases.push_back({"time_step_at_limit", s});
      SetParam(s.params, "cfl_factor", 1.0);
      cases.push_back({"time_step_beyond_limit", s});
    } else {
      SetParam(s.params, "iterations_per_frame", 1);
      SetParam(s.params, "time_scale", 1.0);
      cases.push_back({"time_step_at_limit", s});
      SetParam(s.params, "time_scale", 10.0);
      cases.push_back({"time_step_beyond_limit", s});
    }
  }
  // Both ends of every parameter's range, one at a time. The spacing of a physical solver also
  // scales the scene, so the particle count stays that of the base scene.
  for (const ParamDecl& decl : ParamTable()) {
    for (const double value : {decl.min, decl.max}) {
      Scene s = base;
      SetParam(s.params, decl.name, value);
      if (physical && decl.name == "particle_spacing") {
        const double scale = value / 0.04;
        s.domain = Aabb{base.domain.min * scale, base.domain.max * scale};
        s.fluid_blocks[0].center = *base.fluid_blocks[0].center * scale;
        s.fluid_blocks[0].size = *base.fluid_blocks[0].size * scale;
      }
      cases.push_back({std::string(decl.name) + "=" + (value == decl.min ? "min" : "max"), s});
    }
  }
  return cases;
}

void PrintTo(const StressCase& c, std::ostream* os) { *os << c.solver << " " << c.c.name; }

std::vector<StressCase> AllCases() {
  std::vector<StressCase> out;
  for (const SolverInfo& info : SolverRegistry()) {
    for (Case& c : Cases(info)) out.push_back({std::string(info.name), std::move(c)});
  }
  return out;
}

StressChecker::StressChecker(const Simulation& sim)
    : start_energy_(KineticEnergy(sim) + GravityEnergy(sim)) {}

double StressChecker::bound() const {
  return (warned_ ? kLimitedEnergyMargin : kEnergyMargin) * released_ + kEnergyFloor;
}

std::string StressChecker::AfterStep(const Simulation& sim, int k, bool full) {
  if (k == 1) released_ = start_energy_ + PressureWork(sim);
  warned_ |= !sim.warning().empty();
  std::ostringstream failure;
  failure << "step " << k << ": ";
  if (!sim.alarm().empty()) {
    failure << "alarm: " << sim.alarm();
    return failure.str();
  }
  if (!full) return "";
  const ParticleArrays& p = sim.state().particles;
  if (!StateIsFinite(p)) {
    failure << "a NaN or Inf in a position or velocity";
    return failure.str();
  }
  const Aabb& d = sim.model().domain;
  for (size_t i = 0; i < p.size(); ++i) {
    const Vec3d x = p.position[i].cast<double>();
    if (!((x.array() >= d.min.array()).all() && (x.array() <= d.max.array()).all())) {
      failure << "particle " << p.id[i] << " at " << x.transpose() << " outside the domain";
      return failure.str();
    }
  }
  const double kinetic = KineticEnergy(sim);
  const double budget = bound();
  max_energy_ratio_ = std::max(max_energy_ratio_, kinetic / budget);
  if (!(kinetic <= budget)) {
    failure << "kinetic energy " << kinetic << " J over the bound " << budget << " J; "
            << sim.warning();
    return failure.str();
  }
  return "";
}

RunResult RunCase(const Scene& scene, const RunOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  Simulation sim(scene);
  StressChecker checker(sim);
  RunResult r;
  r.particles = sim.state().particles.size();
  for (int k = 1; k <= options.steps; ++k) {
    sim.Step(options.until);
    r.steps = k;
    const bool last = k == options.steps || sim.state().time >= options.until;
    r.failure = checker.AfterStep(sim, k, k % kCheckEvery == 0 || last);
    if (!r.failure.empty() || last) break;
  }
  r.time = sim.state().time;
  r.max_energy_ratio = checker.max_energy_ratio();
  r.warned = checker.warned();
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

}  // namespace dysa::stress
