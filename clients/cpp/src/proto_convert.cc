#include "proto_convert.h"

#include <array>
#include <utility>

namespace dysa::remote {
namespace {

PassTiming FromProto(const pb::PassTiming& p) {
  return {p.name(), p.last_ms(), p.mean_ms(), p.calls()};
}

std::array<double, 3> FromProto(const pb::Vec3& v) { return {v.x(), v.y(), v.z()}; }

ObstacleMotion FromProto(const pb::ObstacleMotion& m) {
  ObstacleMotion out;
  out.keys.reserve(size_t(m.keys_size()));
  for (const pb::MotionKey& k : m.keys())
    out.keys.push_back({k.time(), FromProto(k.displacement())});
  return out;
}

ParamInfo FromProto(const pb::ParamInfo& p) {
  return {p.name(),        p.value(),
          p.unit(),        p.min(),
          p.max(),         p.default_value(),
          p.integer(),     p.needs_reset(),
          p.description(), {p.solvers().begin(), p.solvers().end()}};
}

}  // namespace

ServerStatus FromProto(const pb::Status& s) {
  ServerStatus out;
  switch (s.state()) {
    case pb::RUN_STATE_RUNNING:
      out.state = "running";
      break;
    case pb::RUN_STATE_PAUSED:
      out.state = "paused";
      break;
    default:
      out.state = "unspecified";
  }
  out.step = s.step();
  out.frame = s.frame();
  out.time = s.time();
  out.particles = s.particles();
  out.solver = s.solver();
  out.scene = s.scene();
  out.frames_per_second = s.frames_per_second();
  out.target_frame_rate = s.target_frame_rate();
  for (const pb::PassTiming& p : s.passes()) out.passes.push_back(FromProto(p));
  out.subscribers = s.subscribers();
  out.alarm = s.alarm();
  out.warning = s.warning();
  out.history_frames = s.history_frames();
  out.solver_threads = s.solver_threads();
  out.history_bytes = s.history_bytes();
  out.frames_encoded = s.frames_encoded();
  out.state_hash = s.state_hash();
  out.scene_version = s.scene_version();
  out.device = s.device();
  out.device_memory_bytes = s.device_memory_bytes();
  for (const pb::StreamStatus& t : s.streams()) {
    out.streams.push_back({t.detail(), t.particles(), t.bytes_per_second(), t.frames_per_second(),
                           t.age_s(), t.link_bytes_per_second(), t.fps_target(), t.byte_budget(),
                           t.particle_budget(), t.stream_id(), t.view()});
  }
  return out;
}

ControlResult FromProto(const pb::ControlReply& r) {
  return {FromProto(r.status()), r.reset(), r.frames_moved()};
}

std::vector<ParamInfo> FromProto(const google::protobuf::RepeatedPtrField<pb::ParamInfo>& ps) {
  std::vector<ParamInfo> out;
  out.reserve(size_t(ps.size()));
  for (const pb::ParamInfo& p : ps) out.push_back(FromProto(p));
  return out;
}

SceneList FromProto(const pb::ListScenesReply& r) {
  SceneList out;
  out.current = r.current();
  for (const pb::SceneInfo& s : r.scenes()) {
    out.scenes.push_back({s.name(), s.description(), s.particles(), s.solver()});
  }
  return out;
}

SceneDescription FromProto(const pb::SceneDescription& s) {
  SceneDescription out;
  out.name = s.name();
  out.description = s.description();
  out.solver = s.solver();
  out.solvers.assign(s.solvers().begin(), s.solvers().end());
  out.domain_min = FromProto(s.domain_min());
  out.domain_max = FromProto(s.domain_max());
  for (const pb::Sphere& sphere : s.spheres()) {
    SphereObstacle& o = out.spheres.emplace_back();
    o.center = FromProto(sphere.center());
    o.radius = sphere.radius();
    o.motion = FromProto(sphere.motion());
  }
  for (const pb::Box& box : s.boxes()) {
    BoxObstacle& o = out.boxes.emplace_back();
    o.min = FromProto(box.min());
    o.max = FromProto(box.max());
    o.motion = FromProto(box.motion());
  }
  out.particle_radius = s.particle_radius();
  out.scene_version = s.scene_version();
  return out;
}

void FromProto(const pb::FrameMessage& m, FrameMessage& out) {
  out.chunks.resize(size_t(m.chunks_size()));
  for (int i = 0; i < m.chunks_size(); ++i) {
    const std::string& bytes = m.chunks(i);
    out.chunks[size_t(i)].assign(bytes.begin(), bytes.end());
  }
  out.frame = m.frame();
  out.last_of_frame = m.last_of_frame();
  out.frame_bytes = m.frame_bytes();
  out.produced_unix_us = m.produced_unix_us();
  out.frames_skipped = m.frames_skipped();
  out.stream_id = m.stream_id();
  out.refines = m.refines();
  out.partial = m.partial();
}

pb::StreamFramesRequest ToProto(const StreamOptions& options) {
  pb::StreamFramesRequest request;
  const std::pair<uint32_t, pb::Field> fields[] = {{codec::kPositions, pb::FIELD_POSITIONS},
                                                   {codec::kSpeed, pb::FIELD_SPEED},
                                                   {codec::kVelocity, pb::FIELD_VELOCITY},
                                                   {codec::kDensity, pb::FIELD_DENSITY}};
  for (const auto& [bit, field] : fields) {
    if (options.fields & bit) request.add_fields(field);
  }
  request.set_max_fps(options.max_fps);
  request.set_stride(options.stride);
  request.set_position_bits(options.position_bits);
  request.set_speed_bits(options.speed_bits);
  request.set_velocity_bits(options.velocity_bits);
  request.set_density_bits(options.density_bits);
  request.set_keyframe_interval(options.keyframe_interval);
  request.set_fps_target(options.fps_target);
  request.set_byte_budget(options.byte_budget);
  request.set_particle_budget(options.particle_budget);
  request.set_velocity_encoding(options.velocity_encoding == codec::VelocityEncoding::kOctahedral
                                    ? pb::VELOCITY_ENCODING_OCTAHEDRAL
                                    : pb::VELOCITY_ENCODING_COMPONENTS);
  return request;
}

}  // namespace dysa::remote
