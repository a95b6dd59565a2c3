#include "dysa/core/simulation.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>

#include "dysa/core/view_selection.h"
#include "dysa/detail_rank.h"
#include "gpu_backend.h"
#include "probe_stages.h"
#include "solvers/seed/seed_solver.h"

namespace dysa {

namespace {

// The spans of `out` as pointers, null where empty; throws std::invalid_argument naming a span
// whose size is not that of n particles.
struct ByIdPointers {
  float* position;
  float* velocity;
  float* density;
};
ByIdPointers CheckedPointers(const Simulation::ParticlesById& out, size_t n, const char* caller) {
  const auto check = [&](std::span<float> span, size_t size, const char* what) {
    if (!span.empty() && span.size() != size) {
      throw std::invalid_argument(std::string(caller) + ": " + what + " holds " +
                                  std::to_string(span.size()) + " floats, not " +
                                  std::to_string(size));
    }
    return span.empty() ? nullptr : span.data();
  };
  return {check(out.position, 3 * n, "position"), check(out.velocity, 3 * n, "velocity"),
          check(out.density, n, "density")};
}

// Scatters a subset packed on a device (in the order of its ids) to the ids' entries.
void ScatterSubset(const RankSubsetCopy& c, const ByIdPointers& to) {
  float *position = to.position, *velocity = to.velocity, *density = to.density;
#pragma omp parallel for schedule(static)
  for (size_t j = 0; j < c.count; ++j) {
    const size_t k = c.ids[j];
    for (int a = 0; a < 3; ++a) {
      if (position) position[3 * k + a] = c.position[3 * j + a];
      if (velocity) velocity[3 * k + a] = c.velocity[3 * j + a];
    }
    if (density) density[k] = c.density[j];
  }
}

}  // namespace

Simulation::Simulation(Scene scene, const Device& device)
    : scene_(std::move(scene)), device_(device) {
  solver_info_ = &FindSolver(scene_.solver);
  solver_ = solver_info_->create();
  model_ = MakeModel(scene_, scene_.params, *solver_info_);
  if (device_.is_cuda()) backend_ = CreateGpuBackend(device_, scene_.solver);
  Rebuild();
  Reset();
}

Simulation::Simulation(Scene scene, const Device& device, const BackendFactory& make)
    : scene_(std::move(scene)), device_(device) {
  solver_info_ = &FindSolver(scene_.solver);
  solver_ = solver_info_->create();
  model_ = MakeModel(scene_, scene_.params, *solver_info_);
  backend_ = make(scene_);
  backend_->CheckParams(model_.params);
  Rebuild();
  Reset();
}

Simulation::~Simulation() = default;
Simulation::Simulation(Simulation&&) noexcept = default;
Simulation& Simulation::operator=(Simulation&&) noexcept = default;

std::vector<double> Simulation::EvaluateProbes(std::span<const ProbeSpec> probes) const {
  const ProbeGatherPlan plan = PlanProbeGather(probes, model_, state_.time);
  ProbeGather gather;
  if (backend_ && host_stale_ && backend_->gathers_probes()) {
    backend_->GatherProbes(plan, gather);
  } else {
    GatherProbes(plan, state().particles, gather);
  }
  return FinishProbes(probes, model_, state_.time, gather);
}

const State& Simulation::state() const {
  if (host_stale_) {
    backend_->Download(state_.particles);
    host_stale_ = false;
  }
  return state_;
}

void Simulation::ReadParticlesById(const ParticlesById& out) const {
  const size_t n = particle_count_;
  const ByIdPointers to = CheckedPointers(out, n, "ReadParticlesById");
  float *position = to.position, *velocity = to.velocity, *density = to.density;
  if (backend_ && host_stale_) {
    backend_->DownloadById(position, velocity, density);
    return;
  }
  const ParticleArrays& p = state_.particles;
#pragma omp parallel for schedule(static)
  for (size_t i = 0; i < n; ++i) {
    const size_t k = p.id[i];
    for (int a = 0; a < 3; ++a) {
      if (position) position[3 * k + a] = p.position[i][a];
      if (velocity) velocity[3 * k + a] = p.velocity[i][a];
    }
    if (density) density[k] = p.density[i];
  }
}

size_t Simulation::ReadParticlesByIdBelowRank(uint32_t threshold, const ParticlesById& out) const {
  const size_t n = particle_count_;
  const auto [position, velocity, density] = CheckedPointers(out, n, "ReadParticlesByIdBelowRank");
  if (threshold == 0) {
    ReadParticlesById(out);
    return n;
  }
  const auto* gpu = dynamic_cast<const GpuBackend*>(backend_.get());
  if (gpu && host_stale_) {
    // Packed in id order on the device; scattered to the ids' entries here.
    const RankSubsetCopy c = gpu->DownloadBelowRank(threshold, position != nullptr,
                                                    velocity != nullptr, density != nullptr);
    ScatterSubset(c, {position, velocity, density});
    return c.count;
  }
  if (host_stale_) {
    const std::optional<size_t> kept =
        backend_->DownloadByIdBelowRank(threshold, position, velocity, density);
    if (kept) return *kept;
  }
  // A scan of the storage (another backend's particles first come to the host whole): the
  // rank is a hash of the id (a few multiplications).
  const ParticleArrays& p = state().particles;
  size_t kept = 0;
#pragma omp parallel for schedule(static) reduction(+ : kept)
  for (size_t i = 0; i < n; ++i) {
    const uint32_t id = p.id[i];
    if (!BelowRank(id, threshold)) continue;
    ++kept;
    const size_t k = id;
    for (int a = 0; a < 3; ++a) {
      if (position) position[3 * k + a] = p.position[i][a];
      if (velocity) velocity[3 * k + a] = p.velocity[i][a];
    }
    if (density) density[k] = p.density[i];
  }
  return kept;
}

size_t Simulation::ReadViewSubset(const ViewSubsetRequest& request, uint64_t budget,
                                  std::vector<uint32_t>& ids, const ParticlesById& out) const {
  const size_t n = particle_count_;
  const ByIdPointers to = CheckedPointers(out, n, "ReadViewSubset");
  if (!request.weigh) throw std::invalid_argument("ReadViewSubset: the request has no weigher");
  const auto* gpu = dynamic_cast<const GpuBackend*>(backend_.get());
  if (gpu && host_stale_) {
    // Chosen and packed in id order on the device; scattered to the ids' entries here.
    const RankSubsetCopy c = gpu->DownloadViewSubset(request, budget, to.position != nullptr,
                                                     to.velocity != nullptr, to.density != nullptr);
    ids.assign(c.ids, c.ids + c.count);
    ScatterSubset(c, to);
    return c.count;
  }
  if (host_stale_) {
    // Chosen where the particles live (the ranks: each offers its own candidates).
    const std::optional<size_t> chosen =
        backend_->SelectViewSubset(request, budget, ids, to.position, to.velocity, to.density);
    if (chosen) return *chosen;
  }
  // On the host: every particle in id order (the keys need every position), then the chosen.
  std::vector<float> position(3 * n), velocity(to.velocity ? 3 * n : 0),
      density(to.density ? n : 0);
  ReadParticlesById({position, velocity, density});
  ids = ViewKeys(position.data(), n, request).Select(budget);
  for (const uint32_t k : ids) {
    for (int a = 0; a < 3; ++a) {
      if (to.position) to.position[3 * k + a] = position[3 * k + a];
      if (to.velocity) to.velocity[3 * k + a] = velocity[3 * k + a];
    }
    if (to.density) to.density[k] = density[k];
  }
  return ids.size();
}

std::string Simulation::DeviceDescription() const {
  return backend_ ? backend_->Describe(device_) : "cpu";
}

uint64_t Simulation::DeviceBytes() const { return backend_ ? backend_->DeviceBytes() : 0; }

std::vector<std::string> Simulation::PassNames() const {
  std::vector<std::string> names;
  for (const PassProfile& prof : profile_) names.push_back(prof.name);
  return names;
}

void Simulation::RecordPassTime(size_t pass, double ms) {
  PassProfile& prof = profile_[pass];
  prof.last_ms = ms;
  prof.total_ms += ms;
  ++prof.calls;
}

void Simulation::Step(double until) {
  using Clock = std::chrono::steady_clock;
  if (!alarm_.empty()) return;
  const double start_time = state_.time;
  const double rest = until - start_time;
  if (model_.physical) {
    state_.max_dt = rest > 0 ? rest : std::numeric_limits<double>::infinity();
  } else {
    state_.dt = model_.dt;
  }
  bool finite = true;
  if (backend_) {
    const StepBackend::StepReport report = backend_->Step(model_, state_);
    for (size_t k = 0; k < report.pass_ms.size() && k < profile_.size(); ++k) {
      RecordPassTime(k, report.pass_ms[k]);
    }
    host_stale_ = true;
    if (!report.alarm.empty()) {
      alarm_ = report.alarm;
      return;
    }
    if (report.max_cell_count > NeighborGrid::kMaxParticlesPerCell) {
      alarm_ = CrowdedAlarm(report.max_cell_count, start_time);
      if (report.stopped) return;
    }
    if (report.limited > 0) {
      state_.warning = seed::VelocityLimiterWarning(report.limited, model_, state_.step + 1);
    }
    finite = report.finite;
  } else {
    for (size_t k = 0; k < passes_.size(); ++k) {
      const auto start = Clock::now();
      passes_[k].run(model_, state_);
      RecordPassTime(k, std::chrono::duration<double, std::milli>(Clock::now() - start).count());
      if (k == sort_pass_ && state_.grid.max_cell_count() > NeighborGrid::kMaxParticlesPerCell) {
        // The neighbour passes would cost O(n^2): stop before them, the state as it was (only
        // reordered), and say why.
        alarm_ = CrowdedAlarm(state_.grid.max_cell_count(), start_time);
        return;
      }
    }
    // About 0.1 ms per 100,000 particles, well under 1% of a step: checked every step so that
    // no later step, probe or frame ever reads a diverged state.
    finite = StateIsFinite(state_.particles);
  }
  // A physical step clamped to the cap lands on `until` itself, not on start + (until - start),
  // which can differ from it in the last bit and leave a sliver of a step.
  state_.time = model_.physical && state_.dt >= state_.max_dt ? until : start_time + state_.dt;
  ++state_.step;
  CheckStep(finite, start_time);
}

std::string Simulation::CrowdedAlarm(uint32_t count, double start_time) const {
  return std::to_string(count) + " particles crowd one neighbour-grid cell at step " +
         std::to_string(state_.step + 1) + " (t = " + std::to_string(start_time) + " s; at most " +
         std::to_string(NeighborGrid::kMaxParticlesPerCell) +
         " can, or each step costs O(n^2)): the fluid collapsed; reset, or space the particles "
         "further apart";
}

void Simulation::CheckStep(bool finite, double start_time) {
  std::string alarm = DivergedStepAlarm(finite, state_, start_time);
  if (!alarm.empty()) alarm_ = std::move(alarm);
}

std::string DivergedStepAlarm(bool finite, const State& state, double start_time) {
  if (!finite) {
    return "non-finite particle state after step " + std::to_string(state.step) +
           " (t = " + std::to_string(start_time) + " s, dt = " + std::to_string(state.dt) +
           " s): the step diverged; reduce the time step or stiffness, or reset";
  }
  if (!(state.dt > 0) || !std::isfinite(state.dt)) {
    return "the time step collapsed to " + std::to_string(state.dt) + " s at step " +
           std::to_string(state.step) + " (t = " + std::to_string(start_time) + " s)";
  }
  return {};
}

void Simulation::UploadParticles(std::span<const SolverArray> solver_arrays) {
  particle_count_ = state_.particles.size();
  if (!backend_) return;
  backend_->Upload(state_.particles, solver_arrays);
  host_stale_ = false;
}

SolverStats Simulation::solver_stats() const {
  return backend_ ? backend_->stats() : solver_->stats();
}

void Simulation::StepFrame() { StepFrame(nullptr); }

bool Simulation::StepFrame(const std::function<bool()>& interrupted) {
  if (!frame_open_) {
    state_.warning.clear();
    // A frame is a fixed slice of simulated time whatever steps the CFL condition allows; its
    // end is fixed here so that resuming a partial frame lands on the same time, bit for bit.
    frame_end_time_ = state_.time + model_.FrameTime();
    frame_steps_left_ = model_.params.iterations_per_frame;
    frame_open_ = true;
  }
  for (bool first = true;; first = false) {
    // A diverged physical frame ends at once; a fixed-step frame counts its (idle) steps, as
    // StepFrame always did.
    const bool complete = model_.physical ? !(state_.time < frame_end_time_ && alarm_.empty())
                                          : frame_steps_left_ <= 0;
    if (complete) break;
    if (!first && interrupted && interrupted()) return false;
    if (model_.physical) {
      Step(frame_end_time_);
    } else {
      Step();
      --frame_steps_left_;
    }
  }
  frame_open_ = false;
  ++state_.frame;
  return true;
}

double Simulation::FrameStepsLeft() const {
  if (!frame_open_) return 0;
  if (!model_.physical) return std::max(frame_steps_left_, 0);
  const double left = frame_end_time_ - state_.time;
  if (left <= 0) return 0;
  return state_.dt > 0 ? std::ceil(left / state_.dt) : 1;
}

void Simulation::Reset() {
  frame_open_ = false;
  alarm_.clear();
  state_.warning.clear();
  SpawnParticles(scene_, model_.params, state_.particles);
  solver_->Reset(state_.particles.size());
  UploadParticles();
  state_.time = 0;
  state_.step = 0;
  state_.frame = 0;
}

size_t Checkpoint::bytes() const {
  size_t bytes = sizeof(Checkpoint) + id.capacity() * sizeof(uint32_t) +
                 (position.capacity() + velocity.capacity()) * sizeof(Vec3);
  for (const SolverArray& array : solver_arrays) {
    bytes += sizeof(SolverArray) + array.name.capacity() + array.values.capacity() * sizeof(Real);
  }
  return bytes;
}

Checkpoint Simulation::SaveCheckpoint() const {
  Checkpoint checkpoint;
  SaveCheckpoint(checkpoint);
  return checkpoint;
}

void Simulation::SaveCheckpoint(Checkpoint& checkpoint) const {
  checkpoint.params = model_.params;
  checkpoint.time = state_.time;
  checkpoint.step = state_.step;
  checkpoint.frame = state_.frame;
  if (backend_) {
    // Only what the checkpoint holds crosses from the GPU; the host copy stays as it was. The
    // checkpoint's arrays lend their memory (the backend resizes them).
    ParticleArrays p;
    p.id = std::move(checkpoint.id);
    p.position = std::move(checkpoint.position);
    p.velocity = std::move(checkpoint.velocity);
    backend_->DownloadCheckpointArrays(p, checkpoint.solver_arrays);
    checkpoint.id = std::move(p.id);
    checkpoint.position = std::move(p.position);
    checkpoint.velocity = std::move(p.velocity);
    return;
  }
  const ParticleArrays& p = state_.particles;
  checkpoint.id.assign(p.id.begin(), p.id.end());
  checkpoint.position.assign(p.position.begin(), p.position.end());
  checkpoint.velocity.assign(p.velocity.begin(), p.velocity.end());
  checkpoint.solver_arrays = solver_->SaveArrays();
}

void Simulation::RestoreCheckpoint(const Checkpoint& checkpoint) {
  model_ = MakeModel(scene_, checkpoint.params, *solver_info_);
  Rebuild();
  frame_open_ = false;
  alarm_.clear();
  state_.warning.clear();
  ParticleArrays& p = state_.particles;
  p.Resize(checkpoint.id.size());
  std::copy(checkpoint.id.begin(), checkpoint.id.end(), p.id.begin());
  std::copy(checkpoint.position.begin(), checkpoint.position.end(), p.position.begin());
  std::copy(checkpoint.velocity.begin(), checkpoint.velocity.end(), p.velocity.begin());
  state_.time = checkpoint.time;
  state_.step = checkpoint.step;
  state_.frame = checkpoint.frame;
  if (backend_) {
    UploadParticles(checkpoint.solver_arrays);
  } else {
    solver_->RestoreArrays(checkpoint.solver_arrays, p.size());
    UploadParticles();
  }
}

bool Simulation::SetParam(std::string_view name, double value) {
  Params next = model_.params;
  dysa::SetParam(next, name, value);  // throws, nothing applied
  return SetParams(next);
}

bool Simulation::SetParams(const Params& params) {
  // Validate every value and the particle count it implies before touching anything.
  Params checked;
  for (const ParamDecl& decl : ParamTable()) dysa::SetParam(checked, decl.name, decl.get(params));
  BlockParticleCounts(scene_, checked);
  if (backend_) backend_->CheckParams(checked);

  bool needs_reset = false;
  for (const ParamDecl& decl : ParamTable()) {
    needs_reset |= decl.needs_reset && decl.get(checked) != decl.get(model_.params);
  }
  model_ = MakeModel(scene_, checked, *solver_info_);
  Rebuild();
  if (needs_reset) Reset();
  return needs_reset;
}

void Simulation::ResetProfile() {
  for (PassProfile& prof : profile_) prof = PassProfile{prof.name};
}

void Simulation::Rebuild() {
  std::vector<std::string> names;
  if (backend_) {
    names = backend_->Configure(model_);
  } else {
    passes_ = solver_->BuildPasses(model_);
    sort_pass_ = passes_.size();
    for (size_t k = 0; k < passes_.size(); ++k) {
      names.push_back(passes_[k].name);
      if (passes_[k].name == kNeighbourSortPass) sort_pass_ = k;
    }
  }
  // Keep the accumulated timings of passes that stay in the list.
  std::vector<PassProfile> profile;
  for (const std::string& name : names) {
    PassProfile prof{name};
    for (const PassProfile& old : profile_) {
      if (old.name == name) prof = old;
    }
    profile.push_back(prof);
  }
  profile_ = std::move(profile);
}

}  // namespace dysa
