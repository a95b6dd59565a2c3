#include "dysa/validation/validation.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <utility>

#include "dysa/core/probes.h"
#include "dysa/core/simulation.h"
#include "dysa/core/solver.h"

namespace dysa {

// MartinMoyce1952Front and MartinMoyce1952ResidualHeight: reference_data.cc.

Scene SlabAtSpacing(Scene scene, double spacing, int layers) {
  SetParam(scene.params, "particle_spacing", spacing);
  const double thickness = layers * spacing;
  const double z0 = scene.domain.min.z();
  const double old_z1 = scene.domain.max.z();
  scene.domain.max.z() = z0 + thickness;
  // An obstacle across the whole depth (a gate) spans the slab.
  for (BoxObstacle& box : scene.boxes) {
    if (box.box.min.z() <= z0 && box.box.max.z() >= old_z1) {
      box.box.min.z() = z0;
      box.box.max.z() = z0 + thickness;
    }
  }
  for (FluidBlock& block : scene.fluid_blocks) {
    Vec3d center = block.center.value_or(scene.domain.Center());
    Vec3d size = block.size.value_or(Vec3d::Constant(scene.params.spawn_size));
    center.z() = z0 + 0.5 * thickness;
    size.z() = thickness;
    block.center = center;
    block.size = size;
  }
  return scene;
}

namespace {

// Slope of the least-squares line through the points (x_k, y_k); 0 for fewer than two x.
double Slope(const std::vector<std::pair<double, double>>& points) {
  double mt = 0, mz = 0;
  for (const auto& [x, y] : points) mt += x / points.size(), mz += y / points.size();
  double sxy = 0, stt = 0;
  for (const auto& [x, y] : points) sxy += (x - mt) * (y - mz), stt += (x - mt) * (x - mt);
  return stt > 0 ? sxy / stt : 0;
}

Scene ValidationScene(const char* name, const ValidationOptions& options) {
  Scene scene = LoadScene(name);
  if (!options.solver.empty()) {
    FindSolver(options.solver);  // throws for an unknown name
    scene.solver = options.solver;
  }
  if (options.slab_layers < 1 || options.slab_layers > 64) {
    throw ConfigError("slab_layers",
                      "must be in [1, 64] particles, got " + std::to_string(options.slab_layers));
  }
  if (options.spacing || options.slab_layers != kSlabLayers) {
    scene = SlabAtSpacing(std::move(scene), options.spacing.value_or(scene.params.particle_spacing),
                          options.slab_layers);
  }
  for (const std::string& assignment : options.sets) SetParamFromString(scene.params, assignment);
  BlockParticleCounts(scene, scene.params);
  return scene;
}

ValidationRun RunInfo(const Simulation& sim) {
  return {sim.scene().solver, sim.params().particle_spacing, sim.particle_count(), sim.step(),
          sim.time()};
}

}  // namespace

double BatchMeansStandardError(const std::vector<double>& batch_means) {
  const size_t n = batch_means.size();
  if (n < 2) return 0;
  double mean = 0;
  for (double m : batch_means) mean += m / double(n);
  double squares = 0;
  for (double m : batch_means) squares += (m - mean) * (m - mean);
  return std::sqrt(squares / (double(n) * double(n - 1)));
}

HydrostaticResult RunHydrostaticTank(const ValidationOptions& options) {
  Simulation sim(ValidationScene("hydrostatic_tank", options), options.device);
  const Scene& scene = sim.scene();
  const double end = scene.end_time;
  HydrostaticResult result;
  const double d = sim.params().particle_spacing;
  const double rho0 = sim.params().rest_density;
  const double g = std::abs(sim.params().gravity);
  const FluidBlock& block = scene.fluid_blocks.at(0);
  const double floor = scene.domain.min.y();
  result.depth = block.size->y();
  const double H = result.depth;
  const Vec3d center = scene.domain.Center();

  std::vector<ProbeSpec> probes;
  for (double y = d; y <= H - kHydrostaticTopLayers * d + 1e-9; y += d) {
    ProbeSpec probe;
    probe.kind = ProbeKind::kPressure;
    probe.point = Vec3d(center.x(), floor + y, center.z());
    probes.push_back(probe);
  }
  // The pressure at each point after every step of the averaging window, weighted by the
  // step's length. Every step, not samples at an interval: dfsph's pressure alternates from
  // one step to the next, and samples every other step would read one phase of it.
  const auto mean_height = [](const ParticleArrays& p) {
    double sum = 0;
    for (const Vec3& x : p.position) sum += double(x.y());
    return p.size() ? sum / double(p.size()) : 0.0;
  };
  const double start_height = mean_height(sim.state().particles);
  const double window_start = std::max(0.0, end - kHydrostaticAveragingTime);
  while (sim.time() < window_start) sim.Step(window_start);
  // The time-weighted sums per part of the window (by the time a step ends in): together they
  // give the window's mean; apart, its standard error.
  std::vector<std::vector<double>> batch_sums(kHydrostaticBatches,
                                              std::vector<double>(probes.size(), 0.0));
  std::vector<double> batch_time(kHydrostaticBatches, 0.0);
  const double batch_length = (end - window_start) / kHydrostaticBatches;
  int samples = 0;
  while (sim.time() < end) {
    sim.Step(end);
    const double dt = sim.last_dt();
    const std::vector<double> p = sim.EvaluateProbes(probes);
    const int batch = std::clamp(int((sim.time() - window_start) / batch_length - 1e-9), 0,
                                 kHydrostaticBatches - 1);
    for (size_t i = 0; i < p.size(); ++i) batch_sums[batch][i] += p[i] * dt;
    batch_time[batch] += dt;
    ++samples;
  }
  result.run = RunInfo(sim);
  result.samples = samples;

  double window = 0;
  for (double t : batch_time) window += t;
  double sum = 0;
  for (size_t i = 0; i < probes.size(); ++i) {
    const double y = probes[i].point.y() - floor;
    double weighted = 0;
    std::vector<double> batch_means;
    for (int b = 0; b < kHydrostaticBatches; ++b) {
      weighted += batch_sums[b][i];
      if (batch_time[b] > 0) batch_means.push_back(batch_sums[b][i] / batch_time[b]);
    }
    const double p = window > 0 ? weighted / window : 0;
    const double reference = rho0 * g * (H - y);
    const double error = std::abs(p - reference) / (rho0 * g * H);
    const double standard_error = BatchMeansStandardError(batch_means);
    result.profile.push_back({y, p, reference, standard_error});
    result.pressure_error_max = std::max(result.pressure_error_max, error);
    result.pressure_error_uncertainty =
        std::max(result.pressure_error_uncertainty, standard_error / (rho0 * g * H));
    sum += error;
  }
  if (!result.profile.empty()) result.pressure_error_mean = sum / double(result.profile.size());
  std::vector<std::pair<double, double>> line;
  for (const HydrostaticResult::Sample& s : result.profile) line.push_back({s.y, s.pressure});
  result.pressure_gradient = -Slope(line);

  const ParticleArrays& p = sim.state().particles;
  double compression = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    const double e = std::max(0.0, double(p.density[i]) / rho0 - 1);
    compression += e;
    result.density_error_max = std::max(result.density_error_max, e);
    result.max_speed = std::max(result.max_speed, double(p.velocity[i].norm()));
  }
  result.density_error_mean = p.size() ? compression / double(p.size()) : 0;
  double bottom = 0;
  int in_bottom = 0;
  for (const Vec3& x : p.position) {
    const double height = (double(x.y()) - floor) / d;
    if (height < 1) bottom += height, ++in_bottom;
  }
  result.bottom_layer_height = in_bottom ? bottom / in_bottom : 0;
  result.settling = (start_height - mean_height(p)) / d;
  result.capped_solves = sim.solver_stats().capped_solves;
  return result;
}

namespace {

DamBreakResult RunDamBreakScene(const char* name, const ValidationOptions& options) {
  Simulation sim(ValidationScene(name, options), options.device);
  const Scene& scene = sim.scene();
  DamBreakResult result;
  const double d = sim.params().particle_spacing;
  const double a = scene.fluid_blocks.at(0).size->x();
  const double g = std::abs(sim.params().gravity);
  const double x_wall = scene.domain.min.x();
  result.column_width = a;
  const double time_unit = std::sqrt(a / (2 * g));  // t = T sqrt(a / (2 g))
  result.time_unit = time_unit;

  // The surge front (the largest x) and the column's height at the wall, evaluated as probes
  // (on a GPU, on the device). The column's surface is half a spacing above its top particle.
  const double support = sim.model().kernel_support;
  ProbeSpec front_probe;
  front_probe.kind = ProbeKind::kFront;
  front_probe.axis = 0;
  ProbeSpec height_probe;
  height_probe.kind = ProbeKind::kHeight;
  height_probe.point = Vec3d(x_wall, 0, scene.domain.Center().z());
  height_probe.radius = support;
  height_probe.gap = support;
  const auto front_Z = [&] {
    return (sim.EvaluateProbes(std::span(&front_probe, 1))[0] + 0.5 * d - x_wall) / a;
  };
  const auto height_H = [&] {
    return (sim.EvaluateProbes(std::span(&height_probe, 1))[0] + 0.5 * d) / (2 * a);
  };
  const double height_time_unit = std::sqrt(a / g);  // t = tau sqrt(a / g)
  // Both tables' times in order; each row is read after the step that reaches its time.
  struct Event {
    double t;
    bool front;
    size_t row;
  };
  std::vector<Event> events;
  const std::vector<MartinMoyceRow>& front_table = MartinMoyce1952Front();
  const std::vector<MartinMoyceHeightRow>& height_table = MartinMoyce1952ResidualHeight();
  for (size_t k = 0; k < front_table.size(); ++k) {
    events.push_back({front_table[k].T * time_unit, true, k});
  }
  for (size_t k = 0; k < height_table.size() && !options.front_only; ++k) {
    events.push_back({height_table[k].tau * height_time_unit, false, k});
  }
  std::stable_sort(events.begin(), events.end(),
                   [](const Event& x, const Event& y) { return x.t < y.t; });
  double sum2 = 0, height_sum2 = 0;
  int count = 0;
  result.trace.push_back({0, front_Z()});
  for (const Event& event : events) {
    while (sim.time() < event.t) {
      sim.Step(event.t);
      result.trace.push_back({sim.time() / time_unit, front_Z()});
    }
    if (!event.front) {
      const MartinMoyceHeightRow& row = height_table[event.row];
      const double H = height_H();
      result.heights.push_back({row.tau, H, row.H});
      const double e = std::abs(H - row.H) / row.H;
      height_sum2 += e * e;
      result.height_max_error = std::max(result.height_max_error, e);
      continue;
    }
    const MartinMoyceRow& row = front_table[event.row];
    const double Z = result.trace.back().Z;
    result.rows.push_back({row.T, Z, row.Z});
    if (row.T > 0) {
      const double e = std::abs(Z - row.Z) / row.Z;
      sum2 += e * e;
      result.max_error = std::max(result.max_error, e);
      ++count;
    }
  }
  if (!result.heights.empty()) {
    result.height_rms_error = std::sqrt(height_sum2 / double(result.heights.size()));
  }
  result.rms_error = count ? std::sqrt(sum2 / count) : 0;
  result.diagnostics = DiagnoseFront(result.trace, MartinMoyce1952Front());
  result.run = RunInfo(sim);
  return result;
}

}  // namespace

DamBreakResult RunDamBreak(const ValidationOptions& options) {
  return RunDamBreakScene("dam_break_martin_moyce", options);
}

DamBreakResult RunGatedDamBreak(const ValidationOptions& options) {
  return RunDamBreakScene("dam_break_martin_moyce_gate", options);
}

double MorrisPoiseuilleSpeed(double x, double t, double force, double viscosity, double width) {
  const double pi = std::numbers::pi;
  double speed = force * x * (width - x) / (2 * viscosity);
  for (int n = 0; n < 200; ++n) {
    const double m = 2 * n + 1;
    speed -= 4 * force * width * width / (viscosity * pi * pi * pi * m * m * m) *
             std::sin(pi * x * m / width) *
             std::exp(-m * m * pi * pi * viscosity * t / (width * width));
  }
  return speed;
}

PoiseuilleResult RunPoiseuille(const ValidationOptions& options) {
  // The slab rule of the other cases does not fit a channel periodic in y and z: here the
  // spacing sets both periods (kPoiseuilleLayers) and the width L stays.
  ValidationOptions channel = options;
  channel.spacing.reset();
  channel.slab_layers = kSlabLayers;
  Scene scene = ValidationScene("poiseuille_flow", channel);
  if (options.spacing) {
    SetParam(scene.params, "particle_spacing", *options.spacing);
    for (const std::string& assignment : options.sets) SetParamFromString(scene.params, assignment);
  }
  const double d = scene.params.particle_spacing;
  for (int k = 0; k < 2; ++k) {
    const int axis = 1 + k;
    scene.domain.max[axis] = scene.domain.min[axis] + kPoiseuilleLayers[k] * d;
  }
  FluidBlock& block = scene.fluid_blocks.at(0);
  block.center = scene.domain.Center();
  block.size = scene.domain.Size();
  BlockParticleCounts(scene, scene.params);

  Simulation sim(scene, options.device);
  PoiseuilleResult result;
  result.width = scene.domain.Size().x();
  result.force = std::abs(sim.params().gravity);
  result.viscosity = sim.params().kinematic_viscosity;
  if (!(result.viscosity > 0)) {
    throw ConfigError("kinematic_viscosity", "Poiseuille flow needs a viscosity above 0");
  }
  result.peak_speed = result.force * result.width * result.width / (8 * result.viscosity);
  const int columns = std::max(1, int(std::lround(result.width / d)));
  const double column = result.width / columns;
  for (const double t : kPoiseuilleTimes) {
    while (sim.time() < t) sim.Step(t);
    PoiseuilleResult::Profile profile;
    profile.t = t;
    std::vector<double> sum(columns, 0.0);
    std::vector<int> count(columns, 0);
    const ParticleArrays& p = sim.state().particles;
    for (size_t i = 0; i < p.size(); ++i) {
      const double x = double(p.position[i].x()) - scene.domain.min.x();
      const int c = std::clamp(int(x / column), 0, columns - 1);
      sum[c] -= double(p.velocity[i].y());
      ++count[c];
    }
    for (int c = 0; c < columns; ++c) {
      if (count[c] == 0) continue;
      const double x = (c + 0.5) * column;
      const double speed = sum[c] / count[c];
      const double reference =
          MorrisPoiseuilleSpeed(x, t, result.force, result.viscosity, result.width);
      profile.x.push_back(x);
      profile.speed.push_back(speed);
      profile.reference.push_back(reference);
      profile.error_max =
          std::max(profile.error_max, std::abs(speed - reference) / result.peak_speed);
    }
    result.error_max = std::max(result.error_max, profile.error_max);
    result.profiles.push_back(std::move(profile));
  }
  result.run = RunInfo(sim);
  return result;
}

namespace {

// Z of the trace at T, linear between samples; the first sample's before it, the last's after.
double FrontAt(const std::vector<FrontSample>& trace, double T) {
  if (T <= trace.front().T) return trace.front().Z;
  if (T >= trace.back().T) return trace.back().Z;
  const auto hi = std::lower_bound(trace.begin(), trace.end(), T,
                                   [](const FrontSample& s, double t) { return s.T < t; });
  const auto lo = hi - 1;
  const double f = (T - lo->T) / (hi->T - lo->T);
  return lo->Z + f * (hi->Z - lo->Z);
}

}  // namespace

FrontError FrontErrorWithDelay(const std::vector<FrontSample>& trace,
                               const std::vector<MartinMoyceRow>& table, double delay) {
  FrontError out;
  if (trace.empty()) return out;
  double sum2 = 0;
  int count = 0;
  for (const MartinMoyceRow& row : table) {
    if (row.T <= 0) continue;
    const double e = std::abs(FrontAt(trace, row.T - delay) - row.Z) / row.Z;
    sum2 += e * e;
    out.max = std::max(out.max, e);
    ++count;
  }
  out.rms = count ? std::sqrt(sum2 / count) : 0;
  return out;
}

FrontDiagnostics DiagnoseFront(const std::vector<FrontSample>& trace,
                               const std::vector<MartinMoyceRow>& table) {
  FrontDiagnostics out;
  if (trace.empty() || table.empty()) return out;
  double best = 1e300;
  for (int k = 0; k <= 1000; ++k) {
    const FrontError e = FrontErrorWithDelay(trace, table, 0.001 * k);
    if (e.rms < best) {
      best = e.rms;
      out.release_delay = 0.001 * k;
      out.delayed = e;
    }
  }
  out.published = FrontErrorWithDelay(trace, table, kPublishedReleaseDelay);
  std::vector<std::pair<double, double>> simulated, reference;
  for (const MartinMoyceRow& row : table) {
    if (row.T < kSurgeFrom - 1e-9) continue;
    simulated.push_back({row.T, FrontAt(trace, row.T)});
    reference.push_back({row.T, row.Z});
  }
  out.front_speed = Slope(simulated);
  out.front_speed_ref = Slope(reference);
  return out;
}

}  // namespace dysa
