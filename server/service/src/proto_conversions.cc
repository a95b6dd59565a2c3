#include "proto_conversions.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "dysa/core/solver.h"
#include "dysa/core/text.h"
#include "rpc_status.h"

namespace dysa::service {
namespace {

// Codec stream settings from a request. Throws std::invalid_argument naming the request field.
SubscriptionOptions ToOptions(const v1::StreamFramesRequest& r) {
  SubscriptionOptions o;
  codec::StreamConfig& c = o.stream;
  // Chunks of 16,384 particles rather than the codec's 65,536: the thesis scene then encodes
  // and decodes as 6 chunks that spread evenly over the threads, not 2 uneven ones (codec_bench
  // --chunk-particles: 5-25% faster both ways, 0.5% larger).
  c.chunk_particles = 1u << 14;
  if (r.fields_size() > 0) c.fields = codec::kPositions;
  for (int f : r.fields()) {
    switch (f) {
      case v1::FIELD_POSITIONS:
        c.fields |= codec::kPositions;
        break;
      case v1::FIELD_SPEED:
        c.fields |= codec::kSpeed;
        break;
      case v1::FIELD_VELOCITY:
        c.fields |= codec::kVelocity;
        break;
      case v1::FIELD_DENSITY:
        c.fields |= codec::kDensity;
        break;
      default:
        throw std::invalid_argument(
            "fields: allowed values FIELD_POSITIONS, FIELD_SPEED, FIELD_VELOCITY, FIELD_DENSITY "
            "(got " +
            std::to_string(f) + ")");
    }
  }
  // Out-of-range values must fail, not wrap: compare before narrowing to int.
  auto bits = [](uint32_t value, int fallback, int max, const char* field) {
    if (value == 0) return fallback;
    if (value > uint32_t(max)) {
      throw std::invalid_argument(std::string(field) + ": allowed range [1, " +
                                  std::to_string(max) + "] bits, or 0 for the default");
    }
    return int(value);
  };
  c.position_bits = bits(r.position_bits(), c.position_bits, 24, "position_bits");
  c.speed_bits = bits(r.speed_bits(), c.speed_bits, 16, "speed_bits");
  c.velocity_bits = bits(r.velocity_bits(), c.velocity_bits, 16, "velocity_bits");
  c.density_bits = bits(r.density_bits(), c.density_bits, 16, "density_bits");
  if (r.keyframe_interval() > 1000000) {
    throw std::invalid_argument("keyframe_interval: allowed range [1, 1000000] frames, or 0");
  }
  if (r.keyframe_interval() != 0) c.keyframe_interval = int(r.keyframe_interval());
  switch (r.velocity_encoding()) {
    case v1::VELOCITY_ENCODING_UNSPECIFIED:
    case v1::VELOCITY_ENCODING_COMPONENTS:
      c.velocity_encoding = codec::VelocityEncoding::kComponents;
      break;
    case v1::VELOCITY_ENCODING_OCTAHEDRAL:
      c.velocity_encoding = codec::VelocityEncoding::kOctahedral;
      break;
    default:
      throw std::invalid_argument(
          "velocity_encoding: allowed values VELOCITY_ENCODING_COMPONENTS, "
          "VELOCITY_ENCODING_OCTAHEDRAL (got " +
          std::to_string(int(r.velocity_encoding())) + ")");
  }
  if (r.stride() != 0) c.stride = r.stride();
  if (!std::isfinite(r.max_fps()) || r.max_fps() < 0 || r.max_fps() > 1000) {
    throw std::invalid_argument("max_fps: allowed range [0, 1000] frames per second");
  }
  o.max_fps = r.max_fps();
  o.budget.fps_target = r.fps_target();
  o.budget.bytes_per_second = double(r.byte_budget());
  o.budget.particles_per_frame = r.particle_budget();
  o.budget.Validate();
  o.ack_token = r.ack_token();
  if (r.fps_target() > 0 && (o.max_fps == 0 || o.max_fps > r.fps_target())) {
    o.max_fps = r.fps_target();
  }
  c.Validate();
  return o;
}

}  // namespace

grpc::Status ToGrpc(ControlCode code, const std::string& message) {
  switch (code) {
    case ControlCode::kOk:
      return grpc::Status::OK;
    case ControlCode::kInvalidArgument:
      return BoundedStatus(grpc::StatusCode::INVALID_ARGUMENT, message);
    case ControlCode::kResourceExhausted:
      return BoundedStatus(grpc::StatusCode::RESOURCE_EXHAUSTED, message);
    case ControlCode::kFailedPrecondition:
      return BoundedStatus(grpc::StatusCode::FAILED_PRECONDITION, message);
    case ControlCode::kUnavailable:
      return BoundedStatus(grpc::StatusCode::UNAVAILABLE, message);
    case ControlCode::kDeadlineExceeded:
      return BoundedStatus(grpc::StatusCode::DEADLINE_EXCEEDED, message);
    case ControlCode::kCancelled:
      return BoundedStatus(grpc::StatusCode::CANCELLED, message);
  }
  return BoundedStatus(grpc::StatusCode::INTERNAL, message);
}

void ToProto(const HostStatus& s, v1::Status& out) {
  out.set_state(s.running ? v1::RUN_STATE_RUNNING : v1::RUN_STATE_PAUSED);
  out.set_step(s.step);
  out.set_frame(s.frame);
  out.set_time(s.time);
  out.set_particles(s.particles);
  out.set_solver(s.solver);
  out.set_scene(s.scene);
  out.set_frames_per_second(s.frames_per_second);
  out.set_target_frame_rate(s.target_frame_rate);
  out.clear_passes();
  for (const PassStatus& p : s.passes) {
    v1::PassTiming& t = *out.add_passes();
    t.set_name(p.name);
    t.set_last_ms(p.last_ms);
    t.set_mean_ms(p.mean_ms);
    t.set_calls(p.calls);
  }
  out.set_subscribers(s.subscribers);
  out.set_alarm(s.alarm);
  out.set_warning(s.warning);
  out.set_history_frames(s.history_frames);
  out.set_history_bytes(s.history_bytes);
  out.set_frames_encoded(s.frames_encoded);
  out.clear_streams();
  for (const StreamReport& r : s.streams) {
    v1::StreamStatus& t = *out.add_streams();
    t.set_detail(r.status.fraction);
    t.set_particles(r.status.particles);
    t.set_bytes_per_second(r.status.bytes_per_second);
    t.set_frames_per_second(r.status.frames_per_second);
    t.set_age_s(r.status.age_s);
    t.set_link_bytes_per_second(r.status.link_bytes_per_second);
    t.set_fps_target(r.budget.fps_target);
    t.set_byte_budget(uint64_t(r.budget.bytes_per_second));
    t.set_particle_budget(uint32_t(r.budget.particles_per_frame));
    t.set_stream_id(r.stream_id);
    t.set_view(r.view);
  }
  out.set_state_hash(s.state_hash);
  out.set_scene_version(s.scene_version);
  out.set_solver_threads(s.solver_threads);
  out.set_device(s.device);
  out.set_device_memory_bytes(s.device_memory_bytes);
}

void ToProto(const Vec3d& v, v1::Vec3& out) {
  out.set_x(v.x());
  out.set_y(v.y());
  out.set_z(v.z());
}

void ToProto(const ObstacleMotion& motion, v1::ObstacleMotion& out) {
  out.clear_keys();
  for (const ObstacleMotion::Key& key : motion.keys) {
    v1::MotionKey& k = *out.add_keys();
    k.set_time(key.time);
    ToProto(key.displacement, *k.mutable_displacement());
  }
}

void ToProto(const HostScene& s, v1::SceneDescription& out) {
  const Scene& scene = s.scene;
  out.set_name(scene.name);
  out.set_description(scene.description);
  out.set_solver(scene.solver);
  out.clear_solvers();
  for (const SolverInfo& info : SolverRegistry()) out.add_solvers(std::string(info.name));
  ToProto(scene.domain.min, *out.mutable_domain_min());
  ToProto(scene.domain.max, *out.mutable_domain_max());
  out.clear_spheres();
  for (const SphereObstacle& sphere : scene.spheres) {
    v1::Sphere& o = *out.add_spheres();
    ToProto(sphere.center, *o.mutable_center());
    o.set_radius(sphere.radius);
    if (sphere.motion.moving()) ToProto(sphere.motion, *o.mutable_motion());
  }
  out.clear_boxes();
  for (const BoxObstacle& box : scene.boxes) {
    v1::Box& o = *out.add_boxes();
    ToProto(box.box.min, *o.mutable_min());
    ToProto(box.box.max, *o.mutable_max());
    if (box.motion.moving()) ToProto(box.motion, *o.mutable_motion());
  }
  out.set_particle_radius(s.particle_radius);
  out.set_scene_version(s.scene_version);
}

void ToProto(const Params& params, google::protobuf::RepeatedPtrField<v1::ParamInfo>& out) {
  out.Clear();
  for (const ParamDecl& d : ParamTable()) {
    v1::ParamInfo& p = *out.Add();
    p.set_name(std::string(d.name));
    p.set_value(d.get(params));
    p.set_unit(std::string(d.unit));
    p.set_min(d.min);
    p.set_max(d.max);
    p.set_default_value(d.DefaultValue());
    p.set_integer(d.integer);
    p.set_needs_reset(d.needs_reset);
    p.set_description(std::string(d.description));
    for (const SolverInfo& solver : SolverRegistry()) {
      if (d.ReadBy(solver.name)) p.add_solvers(std::string(solver.name));
    }
  }
}

void ToProto(const BuiltinSceneText& builtin, v1::SceneInfo& out) {
  const Scene scene = ParseScene(builtin.json);
  uint64_t particles = 0;
  for (const auto& n : BlockParticleCounts(scene, scene.params)) {
    particles += uint64_t(n.x()) * uint64_t(n.y()) * uint64_t(n.z());
  }
  out.set_name(std::string(builtin.name));
  out.set_description(scene.description);
  out.set_particles(uint32_t(particles));
  out.set_solver(scene.solver);
}

grpc::Status ToControl(const v1::UpdateParamsRequest& request, UpdateParamsControl& control) {
  const auto& values = request.params().values();
  if (request.update_mask().paths_size() == 0) {
    for (const auto& [name, value] : values) control.values.emplace_back(name, value);
  } else {
    for (const std::string& path : request.update_mask().paths()) {
      const std::string name = path.starts_with("values.") ? path.substr(7) : path;
      const auto it = values.find(name);
      if (it == values.end()) {
        return {grpc::StatusCode::INVALID_ARGUMENT,
                "update_mask: '" + SafeText(path) + "' has no value in params.values"};
      }
      control.values.emplace_back(name, it->second);
    }
  }
  if (control.values.empty()) {
    return {grpc::StatusCode::INVALID_ARGUMENT,
            "params.values: no parameter given (see GetParams for the names)"};
  }
  // Map order is unspecified; apply in a fixed order so logs and errors are reproducible.
  std::sort(control.values.begin(), control.values.end());
  return grpc::Status::OK;
}

grpc::Status ToControl(const v1::LoadSceneRequest& request, LoadSceneControl& control) {
  // The old scene runs on if this fails. Only built-in names are looked up: a remote caller
  // never makes the server read its files.
  if (!request.solver().empty()) {
    try {
      // Throws ConfigError("solver", ...) quoting the name it is given and listing the known
      // ones. SafeText(name) is the name itself for every registered solver (short, printable)
      // and never a registered name otherwise.
      FindSolver(SafeText(request.solver()));
    } catch (const ConfigError& e) {
      return {grpc::StatusCode::INVALID_ARGUMENT, e.what()};
    }
  }
  Scene& scene = control.scene;
  try {
    switch (request.source_case()) {
      case v1::LoadSceneRequest::kName: {
        const std::vector<std::string> names = BuiltinSceneNames();
        if (std::find(names.begin(), names.end(), request.name()) == names.end()) {
          std::string known;
          for (const std::string& n : names) known += (known.empty() ? "" : ", ") + n;
          return {grpc::StatusCode::INVALID_ARGUMENT,
                  "name: no built-in scene '" + SafeText(request.name()) + "' (known: " + known +
                      "); to load a scene file, send its content as json_text"};
        }
        scene = dysa::LoadScene(request.name());
        break;
      }
      case v1::LoadSceneRequest::kJsonText:
        scene = ParseScene(request.json_text());
        break;
      default:
        return {grpc::StatusCode::INVALID_ARGUMENT,
                "source: give a built-in scene name or json_text"};
    }
  } catch (const ConfigError& e) {
    return {grpc::StatusCode::INVALID_ARGUMENT, std::string("scene: ") + e.what()};
  }
  if (!request.solver().empty()) scene.solver = request.solver();
  return grpc::Status::OK;
}

grpc::Status ToOptions(const grpc::ByteBuffer& request, SubscriptionOptions& options) {
  v1::StreamFramesRequest parsed;
  std::vector<grpc::Slice> slices;
  std::string bytes;
  if (request.Dump(&slices).ok()) {
    for (const grpc::Slice& slice : slices) {
      bytes.append(reinterpret_cast<const char*>(slice.begin()), slice.size());
    }
  }
  if (!parsed.ParseFromString(bytes)) {
    return {grpc::StatusCode::INVALID_ARGUMENT, "request: not a StreamFramesRequest"};
  }
  try {
    options = ToOptions(parsed);
  } catch (const std::invalid_argument& e) {
    return {grpc::StatusCode::INVALID_ARGUMENT, e.what()};
  }
  return grpc::Status::OK;
}

StreamView ToView(const v1::SetStreamViewRequest& r) {
  const auto vec = [](const v1::Vec3& v) { return std::array<double, 3>{v.x(), v.y(), v.z()}; };
  StreamView view;
  view.eye = vec(r.eye());
  view.target = vec(r.target());
  if (r.has_up()) view.up = vec(r.up());
  if (r.fov_y_deg() != 0) view.fov_y_deg = r.fov_y_deg();
  if (r.aspect() != 0) view.aspect = r.aspect();
  return view;
}

}  // namespace dysa::service
