#include "simulation_service.h"

#include <algorithm>
#include <cmath>

#include "dysa/core/params.h"
#include "dysa/core/scene.h"
#include "dysa/core/solver.h"
#include "dysa/core/types.h"

namespace dysa::service {

namespace {

// Messages stay under gRPC's 4 MiB default whatever the client's limit; chunks are far smaller
// (65,536 particles each), so a frame is cut at chunk boundaries.
constexpr size_t kMaxMessageBytes = size_t{3} << 20;

grpc::Status ToGrpc(ControlCode code, const std::string& message) {
  switch (code) {
    case ControlCode::kOk:
      return grpc::Status::OK;
    case ControlCode::kInvalidArgument:
      return {grpc::StatusCode::INVALID_ARGUMENT, message};
    case ControlCode::kResourceExhausted:
      return {grpc::StatusCode::RESOURCE_EXHAUSTED, message};
    case ControlCode::kFailedPrecondition:
      return {grpc::StatusCode::FAILED_PRECONDITION, message};
    case ControlCode::kUnavailable:
      return {grpc::StatusCode::UNAVAILABLE, message};
  }
  return {grpc::StatusCode::INTERNAL, message};
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
  }
  out.clear_boxes();
  for (const BoxObstacle& box : scene.boxes) {
    v1::Box& o = *out.add_boxes();
    ToProto(box.box.min, *o.mutable_min());
    ToProto(box.box.max, *o.mutable_max());
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
  }
}

// Codec stream settings from a request; zero means the default. Throws std::invalid_argument
// naming the request field.
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
  c.Validate();
  return o;
}

// A frame as serialised FrameMessages, each at most kMaxMessageBytes of chunks. Only
// frames_skipped differs between subscribers: it is appended to a message as its own field
// (protobuf fields may come in any order), so the shared slices are never copied.
struct WireFrame {
  std::vector<grpc::Slice> messages;
};

std::shared_ptr<const void> BuildWireFrame(const EncodedFrame& frame) {
  auto wire = std::make_shared<WireFrame>();
  v1::FrameMessage message;
  size_t next = 0;
  do {
    message.Clear();
    size_t bytes = 0;
    while (next < frame.chunks.size()) {
      const codec::Chunk& chunk = frame.chunks[next];
      if (message.chunks_size() > 0 && bytes + chunk.size() > kMaxMessageBytes) break;
      message.add_chunks(chunk.data(), chunk.size());
      bytes += chunk.size();
      ++next;
    }
    message.set_frame(frame.frame);
    message.set_last_of_frame(next == frame.chunks.size());
    message.set_frame_bytes(frame.bytes);
    message.set_produced_unix_us(frame.produced_unix_us);
    auto* text = new std::string(message.SerializeAsString());
    wire->messages.emplace_back(
        text->data(), text->size(), [](void* p) { delete static_cast<std::string*>(p); }, text);
  } while (next < frame.chunks.size());
  return wire;
}

// FrameMessage.frames_skipped (field 6, varint) on its own.
grpc::Slice SkippedField(uint32_t skipped) {
  uint8_t bytes[6] = {6 << 3};
  size_t n = 1;
  do {
    bytes[n++] = uint8_t((skipped & 0x7f) | (skipped >= 0x80 ? 0x80 : 0));
    skipped >>= 7;
  } while (skipped != 0);
  return grpc::Slice(bytes, n);
}

// One StreamFrames call: takes the newest decodable frame from its subscription whenever no
// write is in flight, and sends its messages one after the other. A new frame's first write is
// started on the WriteStarter's thread, the others on gRPC's (OnWriteDone).
class FrameStream final : public grpc::ServerWriteReactor<grpc::ByteBuffer>,
                          public FrameListener,
                          private WriteStarter::Writer {
 public:
  FrameStream(FrameHub& hub, WriteStarter& starter) : hub_(hub), starter_(starter) {}

  // Subscribes, or finishes the call with the reason it cannot.
  void Begin(const SubscriptionOptions& options) {
    // Held so that a frame published before subscription_ is set waits for it.
    std::lock_guard lock(mu_);
    try {
      subscription_ = hub_.Subscribe(options, this);
    } catch (const SubscriberLimitError& e) {
      FinishLocked({grpc::StatusCode::RESOURCE_EXHAUSTED, e.what()});
    }
  }
  void FinishNow(const grpc::Status& status) {
    std::lock_guard lock(mu_);
    FinishLocked(status);
  }

  // On the simulation's thread: no lock of ours (a gRPC thread may hold it inside StartWrite).
  void OnFrameReady() override { starter_.Schedule(this); }
  void OnHubClosed() override {
    std::lock_guard lock(mu_);
    closing_ = true;
    if (!writing_) FinishLocked({grpc::StatusCode::UNAVAILABLE, "the server is shutting down"});
  }

  void OnWriteDone(bool ok) override {
    std::lock_guard lock(mu_);
    writing_ = false;
    // A write in flight when the call was cancelled can still complete ok: the stream must end
    // here then, not wait for a frame that may never come (a paused server).
    if (!ok || cancelled_) {
      FinishLocked({grpc::StatusCode::CANCELLED, "the stream was cancelled"});
    } else if (closing_) {
      FinishLocked({grpc::StatusCode::UNAVAILABLE, "the server is shutting down"});
    } else if (!finished_) {
      WriteNextLocked();
    }
  }
  void OnCancel() override {
    std::lock_guard lock(mu_);
    cancelled_ = true;
    if (!writing_) FinishLocked({grpc::StatusCode::CANCELLED, "the stream was cancelled"});
  }
  void OnDone() override {
    if (subscription_) hub_.Unsubscribe(subscription_);  // no OnFrameReady after this returns
    starter_.Forget(this);                               // nor a StartNextWrite after this
    delete this;
  }

 private:
  void StartNextWrite() override {
    std::lock_guard lock(mu_);
    if (!writing_ && !finished_ && subscription_) WriteNextLocked();
  }

  void FinishLocked(const grpc::Status& status) {
    if (finished_) return;
    finished_ = true;
    Finish(status);
  }

  // The next message of the current frame, or the first of the next frame.
  void WriteNextLocked() {
    grpc::Slice slices[2];
    size_t count = 1;
    if (!wire_ || next_message_ == wire_->messages.size()) {
      uint32_t skipped = 0;
      frame_ = subscription_->Take(&skipped);
      if (!frame_) {  // OnFrameReady will follow
        wire_ = nullptr;
        return;
      }
      wire_ = static_cast<const WireFrame*>(frame_->transport.get());
      next_message_ = 0;
      if (skipped > 0) slices[count++] = SkippedField(skipped);
    }
    slices[0] = wire_->messages[next_message_++];
    message_ = grpc::ByteBuffer(slices, count);
    writing_ = true;
    StartWrite(&message_);
  }

  FrameHub& hub_;
  WriteStarter& starter_;
  std::shared_ptr<Subscription> subscription_;
  std::mutex mu_;
  bool writing_ = false;
  bool finished_ = false;
  bool closing_ = false;
  bool cancelled_ = false;
  std::shared_ptr<const EncodedFrame> frame_;  // being sent; owns wire_
  const WireFrame* wire_ = nullptr;
  size_t next_message_ = 0;
  grpc::ByteBuffer message_;  // the write in flight
};

}  // namespace

grpc::Status SimulationService::CheckAccess(const grpc::CallbackServerContext* context,
                                            Access access) const {
  if (access_.token.empty() || (access == Access::kWatch && !access_.protect_watch)) {
    return grpc::Status::OK;
  }
  const auto& metadata = context->client_metadata();
  const auto it = metadata.find("authorization");
  if (it == metadata.end()) {
    return {grpc::StatusCode::UNAUTHENTICATED,
            "this server needs a token: metadata 'authorization: Bearer <token>' (dysa --token)"};
  }
  const std::string expected = "Bearer " + access_.token;
  const std::string_view given(it->second.data(), it->second.size());
  // Compare in time independent of where the first difference is.
  unsigned diff = given.size() != expected.size();
  for (size_t i = 0; i < std::min(given.size(), expected.size()); ++i) {
    diff |= unsigned(given[i] ^ expected[i]);
  }
  if (diff != 0) return {grpc::StatusCode::UNAUTHENTICATED, "wrong token"};
  return grpc::Status::OK;
}

grpc::ServerUnaryReactor* SimulationService::SubmitControl(grpc::CallbackServerContext* context,
                                                           Control control,
                                                           v1::ControlReply* reply) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  if (grpc::Status s = CheckAccess(context, Access::kControl); !s.ok()) {
    reactor->Finish(s);
    return reactor;
  }
  host_.Submit(std::move(control), [reactor, reply](ControlResult r) {
    if (r.code == ControlCode::kOk) {
      ToProto(r.status, *reply->mutable_status());
      reply->set_reset(r.reset);
      reply->set_frames_moved(r.frames_moved);
    }
    reactor->Finish(ToGrpc(r.code, r.message));
  });
  return reactor;
}

grpc::ServerUnaryReactor* SimulationService::GetStatus(grpc::CallbackServerContext* context,
                                                       const v1::GetStatusRequest*,
                                                       v1::Status* reply) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  grpc::Status s = CheckAccess(context, Access::kWatch);
  if (s.ok()) ToProto(host_.Status(), *reply);
  reactor->Finish(s);
  return reactor;
}

grpc::ServerUnaryReactor* SimulationService::Pause(grpc::CallbackServerContext* context,
                                                   const v1::PauseRequest*,
                                                   v1::ControlReply* reply) {
  return SubmitControl(context, PauseControl{}, reply);
}

grpc::ServerUnaryReactor* SimulationService::Resume(grpc::CallbackServerContext* context,
                                                    const v1::ResumeRequest*,
                                                    v1::ControlReply* reply) {
  return SubmitControl(context, ResumeControl{}, reply);
}

grpc::ServerUnaryReactor* SimulationService::Step(grpc::CallbackServerContext* context,
                                                  const v1::StepRequest* request,
                                                  v1::ControlReply* reply) {
  return SubmitControl(context, StepControl{std::max(request->count(), 1u)}, reply);
}

grpc::ServerUnaryReactor* SimulationService::StepBack(grpc::CallbackServerContext* context,
                                                      const v1::StepBackRequest* request,
                                                      v1::ControlReply* reply) {
  return SubmitControl(context, StepBackControl{std::max(request->count(), 1u)}, reply);
}

grpc::ServerUnaryReactor* SimulationService::Reset(grpc::CallbackServerContext* context,
                                                   const v1::ResetRequest*,
                                                   v1::ControlReply* reply) {
  return SubmitControl(context, ResetControl{}, reply);
}

grpc::ServerUnaryReactor* SimulationService::GetParams(grpc::CallbackServerContext* context,
                                                       const v1::GetParamsRequest*,
                                                       v1::ParamsReply* reply) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  grpc::Status s = CheckAccess(context, Access::kWatch);
  if (s.ok()) ToProto(host_.CurrentParams(), *reply->mutable_params());
  reactor->Finish(s);
  return reactor;
}

grpc::ServerUnaryReactor* SimulationService::UpdateParams(grpc::CallbackServerContext* context,
                                                          const v1::UpdateParamsRequest* request,
                                                          v1::UpdateParamsReply* reply) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  if (grpc::Status s = CheckAccess(context, Access::kControl); !s.ok()) {
    reactor->Finish(s);
    return reactor;
  }
  const auto& values = request->params().values();
  UpdateParamsControl control;
  if (request->update_mask().paths_size() == 0) {
    for (const auto& [name, value] : values) control.values.emplace_back(name, value);
  } else {
    for (const std::string& path : request->update_mask().paths()) {
      const std::string name = path.starts_with("values.") ? path.substr(7) : path;
      const auto it = values.find(name);
      if (it == values.end()) {
        reactor->Finish({grpc::StatusCode::INVALID_ARGUMENT,
                         "update_mask: '" + path + "' has no value in params.values"});
        return reactor;
      }
      control.values.emplace_back(name, it->second);
    }
  }
  if (control.values.empty()) {
    reactor->Finish({grpc::StatusCode::INVALID_ARGUMENT,
                     "params.values: no parameter given (see GetParams for the names)"});
    return reactor;
  }
  // Map order is unspecified; apply in a fixed order so logs and errors are reproducible.
  std::sort(control.values.begin(), control.values.end());
  host_.Submit(std::move(control), [reactor, reply](ControlResult r) {
    if (r.code == ControlCode::kOk) {
      reply->set_reset(r.reset);
      ToProto(r.params, *reply->mutable_params());
      ToProto(r.status, *reply->mutable_status());
    }
    reactor->Finish(ToGrpc(r.code, r.message));
  });
  return reactor;
}

grpc::ServerUnaryReactor* SimulationService::LoadScene(grpc::CallbackServerContext* context,
                                                       const v1::LoadSceneRequest* request,
                                                       v1::ControlReply* reply) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  if (grpc::Status s = CheckAccess(context, Access::kControl); !s.ok()) {
    reactor->Finish(s);
    return reactor;
  }
  // Parsed here, off the simulation thread; the old scene runs on if this fails. Only built-in
  // names are looked up: a remote caller never makes the server read its files.
  if (!request->solver().empty()) {
    try {
      CreateSolver(request->solver());  // throws ConfigError("solver", ...) listing the names
    } catch (const ConfigError& e) {
      reactor->Finish({grpc::StatusCode::INVALID_ARGUMENT, e.what()});
      return reactor;
    }
  }
  Scene scene;
  try {
    switch (request->source_case()) {
      case v1::LoadSceneRequest::kName: {
        const std::vector<std::string> names = BuiltinSceneNames();
        if (std::find(names.begin(), names.end(), request->name()) == names.end()) {
          std::string known;
          for (const std::string& n : names) known += (known.empty() ? "" : ", ") + n;
          reactor->Finish({grpc::StatusCode::INVALID_ARGUMENT,
                           "name: no built-in scene '" + request->name() + "' (known: " + known +
                               "); send a scene file's content as json_text"});
          return reactor;
        }
        scene = dysa::LoadScene(request->name());
        break;
      }
      case v1::LoadSceneRequest::kJsonText:
        scene = ParseScene(request->json_text());
        break;
      default:
        reactor->Finish({grpc::StatusCode::INVALID_ARGUMENT,
                         "source: give a built-in scene name or json_text"});
        return reactor;
    }
  } catch (const ConfigError& e) {
    reactor->Finish({grpc::StatusCode::INVALID_ARGUMENT, std::string("scene: ") + e.what()});
    return reactor;
  }
  if (!request->solver().empty()) scene.solver = request->solver();
  host_.Submit(LoadSceneControl{std::move(scene)}, [reactor, reply](ControlResult r) {
    if (r.code == ControlCode::kOk) {
      ToProto(r.status, *reply->mutable_status());
      reply->set_reset(true);
    }
    reactor->Finish(ToGrpc(r.code, r.message));
  });
  return reactor;
}

grpc::ServerUnaryReactor* SimulationService::ListScenes(grpc::CallbackServerContext* context,
                                                        const v1::ListScenesRequest*,
                                                        v1::ListScenesReply* reply) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  if (grpc::Status s = CheckAccess(context, Access::kWatch); !s.ok()) {
    reactor->Finish(s);
    return reactor;
  }
  for (const BuiltinSceneText& builtin : BuiltinSceneTexts()) {
    const Scene scene = ParseScene(builtin.json);
    uint64_t particles = 0;
    for (const auto& n : BlockParticleCounts(scene, scene.params)) {
      particles += uint64_t(n.x()) * uint64_t(n.y()) * uint64_t(n.z());
    }
    v1::SceneInfo& info = *reply->add_scenes();
    info.set_name(std::string(builtin.name));
    info.set_description(scene.description);
    info.set_particles(uint32_t(particles));
    info.set_solver(scene.solver);
  }
  reply->set_current(host_.Status().scene);
  reactor->Finish(grpc::Status::OK);
  return reactor;
}

grpc::ServerUnaryReactor* SimulationService::GetScene(grpc::CallbackServerContext* context,
                                                      const v1::GetSceneRequest*,
                                                      v1::SceneDescription* reply) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  grpc::Status s = CheckAccess(context, Access::kWatch);
  if (s.ok()) ToProto(host_.CurrentScene(), *reply);
  reactor->Finish(s);
  return reactor;
}

SimulationService::SimulationService(SimulationHost& host, AccessPolicy access)
    : host_(host), access_(std::move(access)) {
  host_.hub().set_transport_builder(BuildWireFrame);
}

grpc::ServerWriteReactor<grpc::ByteBuffer>* SimulationService::StreamFrames(
    grpc::CallbackServerContext* context, const grpc::ByteBuffer* request) {
  auto* stream = new FrameStream(host_.hub(), write_starter_);  // deletes itself in OnDone
  if (grpc::Status s = CheckAccess(context, Access::kWatch); !s.ok()) {
    stream->FinishNow(s);
    return stream;
  }
  v1::StreamFramesRequest parsed;
  std::vector<grpc::Slice> slices;
  std::string bytes;
  if (request->Dump(&slices).ok()) {
    for (const grpc::Slice& slice : slices) {
      bytes.append(reinterpret_cast<const char*>(slice.begin()), slice.size());
    }
  }
  if (!parsed.ParseFromString(bytes)) {
    stream->FinishNow({grpc::StatusCode::INVALID_ARGUMENT, "request: not a StreamFramesRequest"});
    return stream;
  }
  try {
    stream->Begin(ToOptions(parsed));
  } catch (const std::invalid_argument& e) {
    stream->FinishNow({grpc::StatusCode::INVALID_ARGUMENT, e.what()});
  }
  return stream;
}

}  // namespace dysa::service
