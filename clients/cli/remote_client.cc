#include "remote_client.h"

#include <grpcpp/grpcpp.h>

#include <array>
#include <atomic>
#include <fstream>
#include <functional>
#include <sstream>

#include "dysa/v1/simulation.grpc.pb.h"

namespace dysa::remote {
namespace {

namespace pb = ::dysa::v1;

std::string ReadTextFile(const std::string& path, const std::string& what) {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw std::runtime_error("cannot read " + what + " " + path);
  std::stringstream text;
  text << file.rdbuf();
  return text.str();
}

std::shared_ptr<grpc::ChannelCredentials> Credentials(const ConnectOptions& options) {
  if (options.tls_ca_file.empty()) return grpc::InsecureChannelCredentials();
  grpc::SslCredentialsOptions ssl;
  ssl.pem_root_certs = ReadTextFile(options.tls_ca_file, "TLS CA file");
  return grpc::SslCredentials(ssl);
}

PassTiming FromProto(const pb::PassTiming& p) {
  return {p.name(), p.last_ms(), p.mean_ms(), p.calls()};
}

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
  return out;
}

std::array<double, 3> FromProto(const pb::Vec3& v) { return {v.x(), v.y(), v.z()}; }

SceneDescription FromProto(const pb::SceneDescription& s) {
  SceneDescription out;
  out.name = s.name();
  out.description = s.description();
  out.solver = s.solver();
  out.solvers.assign(s.solvers().begin(), s.solvers().end());
  out.domain_min = FromProto(s.domain_min());
  out.domain_max = FromProto(s.domain_max());
  for (const pb::Sphere& sphere : s.spheres()) {
    out.spheres.push_back({FromProto(sphere.center()), sphere.radius()});
  }
  for (const pb::Box& box : s.boxes())
    out.boxes.push_back({FromProto(box.min()), FromProto(box.max())});
  out.particle_radius = s.particle_radius();
  out.scene_version = s.scene_version();
  return out;
}

ControlResult FromProto(const pb::ControlReply& r) {
  return {FromProto(r.status()), r.reset(), r.frames_moved()};
}

ParamInfo FromProto(const pb::ParamInfo& p) {
  return {p.name(),          p.value(),   p.unit(),        p.min(),        p.max(),
          p.default_value(), p.integer(), p.needs_reset(), p.description()};
}

std::vector<ParamInfo> FromProto(const google::protobuf::RepeatedPtrField<pb::ParamInfo>& ps) {
  std::vector<ParamInfo> out;
  out.reserve(size_t(ps.size()));
  for (const pb::ParamInfo& p : ps) out.push_back(FromProto(p));
  return out;
}

// The error a failed call throws. Adds what the bare gRPC message leaves out: which server
// could not be reached, and how to pass a token.
RpcError ToError(const grpc::Status& status, const ConnectOptions& options,
                 std::chrono::milliseconds deadline) {
  const int code = int(status.error_code());
  std::string message = status.error_message();
  switch (status.error_code()) {
    case grpc::StatusCode::UNAVAILABLE:
      if (message.find("connect") == std::string::npos) {
        message = "server at " + options.address + ": " + message;
        break;
      }
      message =
          "cannot connect to the server at " + options.address +
          (message.find("refused") != std::string::npos ? " (is dysa-server running there?)" : "") +
          ": " + message;
      // Hints for the usual TLS mix-ups, which gRPC reports as bare transport errors.
      if (options.tls_ca_file.empty() && message.find("Socket closed") != std::string::npos) {
        message += " (if the server uses TLS, pass --tls-ca)";
      } else if (!options.tls_ca_file.empty() &&
                 message.find("peer certificate") != std::string::npos) {
        message += " (--tls-name gives the name the certificate carries)";
      }
      break;
    case grpc::StatusCode::DEADLINE_EXCEEDED:
      if (deadline.count() > 0) {
        std::ostringstream text;
        text << " (no answer from " << options.address << " within " << deadline.count() / 1000.0
             << " s)";
        message += text.str();
      }
      break;
    case grpc::StatusCode::UNAUTHENTICATED:
      if (options.token.empty()) message += " (pass --token or set DYSA_TOKEN)";
      break;
    default:
      break;
  }
  return RpcError(code, StatusCodeName(code), message);
}

void PrepareContext(grpc::ClientContext& context, const ConnectOptions& options) {
  if (!options.token.empty()) context.AddMetadata("authorization", "Bearer " + options.token);
}

}  // namespace

RpcError::RpcError(int code, std::string code_name, std::string message)
    : std::runtime_error(code_name + ": " + message),
      code_(code),
      code_name_(std::move(code_name)),
      message_(std::move(message)) {}

std::string StatusCodeName(int code) {
  static constexpr std::array<const char*, 17> kNames = {"OK",
                                                         "CANCELLED",
                                                         "UNKNOWN",
                                                         "INVALID_ARGUMENT",
                                                         "DEADLINE_EXCEEDED",
                                                         "NOT_FOUND",
                                                         "ALREADY_EXISTS",
                                                         "PERMISSION_DENIED",
                                                         "RESOURCE_EXHAUSTED",
                                                         "FAILED_PRECONDITION",
                                                         "ABORTED",
                                                         "OUT_OF_RANGE",
                                                         "UNIMPLEMENTED",
                                                         "INTERNAL",
                                                         "UNAVAILABLE",
                                                         "DATA_LOSS",
                                                         "UNAUTHENTICATED"};
  if (code >= 0 && size_t(code) < kNames.size()) return kNames[size_t(code)];
  return "CODE_" + std::to_string(code);
}

// ---------------------------------------------------------------------------------------------

struct FrameStream::Impl {
  ConnectOptions options;
  grpc::ClientContext context;
  std::unique_ptr<grpc::ClientReader<pb::FrameMessage>> reader;
  pb::FrameMessage message;
  std::atomic<bool> cancelled{false};
  bool finished = false;
};

FrameStream::FrameStream(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

FrameStream::~FrameStream() {
  if (impl_->finished) return;
  // The call must be finished before its context goes away; drain what is in flight first.
  impl_->context.TryCancel();
  while (impl_->reader->Read(&impl_->message)) {
  }
  impl_->reader->Finish();
}

bool FrameStream::Next(FrameMessage& out) {
  if (impl_->finished || !impl_->reader->Read(&impl_->message)) return false;
  const pb::FrameMessage& m = impl_->message;
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
  return true;
}

void FrameStream::Cancel() {
  impl_->cancelled = true;
  impl_->context.TryCancel();
}

void FrameStream::Finish() {
  if (impl_->finished) return;
  while (impl_->reader->Read(&impl_->message)) {
  }
  const grpc::Status status = impl_->reader->Finish();
  impl_->finished = true;
  if (status.ok()) return;
  if (status.error_code() == grpc::StatusCode::CANCELLED && impl_->cancelled) return;
  throw ToError(status, impl_->options, std::chrono::milliseconds(0));
}

// ---------------------------------------------------------------------------------------------

struct Client::Impl {
  ConnectOptions options;
  std::unique_ptr<pb::Simulation::Stub> stub;

  // Runs one unary call with the token and a deadline; throws RpcError unless it succeeds.
  template <class Call>
  void Invoke(std::chrono::milliseconds deadline, Call&& call) {
    grpc::ClientContext context;
    PrepareContext(context, options);
    context.set_deadline(std::chrono::system_clock::now() + deadline);
    const grpc::Status status = call(&context);
    if (!status.ok()) throw ToError(status, options, deadline);
  }

  ControlResult Control(
      const std::function<grpc::Status(grpc::ClientContext*, pb::ControlReply*)>& call) {
    pb::ControlReply reply;
    Invoke(options.control_deadline, [&](grpc::ClientContext* c) { return call(c, &reply); });
    return FromProto(reply);
  }
};

Client::Client(const ConnectOptions& options) : impl_(std::make_unique<Impl>()) {
  impl_->options = options;
  grpc::ChannelArguments args;
  if (!options.tls_server_name.empty()) args.SetSslTargetNameOverride(options.tls_server_name);
  impl_->stub = pb::Simulation::NewStub(
      grpc::CreateCustomChannel(options.address, Credentials(options), args));
}

Client::~Client() = default;

const std::string& Client::address() const { return impl_->options.address; }

ServerStatus Client::GetStatus() {
  pb::Status reply;
  impl_->Invoke(impl_->options.query_deadline, [&](grpc::ClientContext* c) {
    return impl_->stub->GetStatus(c, pb::GetStatusRequest(), &reply);
  });
  return FromProto(reply);
}

ControlResult Client::Pause() {
  return impl_->Control([&](grpc::ClientContext* c, pb::ControlReply* r) {
    return impl_->stub->Pause(c, pb::PauseRequest(), r);
  });
}

ControlResult Client::Resume() {
  return impl_->Control([&](grpc::ClientContext* c, pb::ControlReply* r) {
    return impl_->stub->Resume(c, pb::ResumeRequest(), r);
  });
}

ControlResult Client::Step(uint32_t count) {
  pb::StepRequest request;
  request.set_count(count);
  return impl_->Control([&](grpc::ClientContext* c, pb::ControlReply* r) {
    return impl_->stub->Step(c, request, r);
  });
}

ControlResult Client::StepBack(uint32_t count) {
  pb::StepBackRequest request;
  request.set_count(count);
  return impl_->Control([&](grpc::ClientContext* c, pb::ControlReply* r) {
    return impl_->stub->StepBack(c, request, r);
  });
}

ControlResult Client::Reset() {
  return impl_->Control([&](grpc::ClientContext* c, pb::ControlReply* r) {
    return impl_->stub->Reset(c, pb::ResetRequest(), r);
  });
}

std::vector<ParamInfo> Client::GetParams() {
  pb::ParamsReply reply;
  impl_->Invoke(impl_->options.query_deadline, [&](grpc::ClientContext* c) {
    return impl_->stub->GetParams(c, pb::GetParamsRequest(), &reply);
  });
  return FromProto(reply.params());
}

UpdateResult Client::UpdateParams(const std::vector<std::pair<std::string, double>>& values) {
  pb::UpdateParamsRequest request;
  for (const auto& [name, value] : values) {
    (*request.mutable_params()->mutable_values())[name] = value;
    request.mutable_update_mask()->add_paths(name);
  }
  pb::UpdateParamsReply reply;
  impl_->Invoke(impl_->options.control_deadline, [&](grpc::ClientContext* c) {
    return impl_->stub->UpdateParams(c, request, &reply);
  });
  return {reply.reset(), FromProto(reply.params()), FromProto(reply.status())};
}

ControlResult Client::LoadSceneByName(const std::string& name, const std::string& solver) {
  pb::LoadSceneRequest request;
  request.set_name(name);
  request.set_solver(solver);
  return impl_->Control([&](grpc::ClientContext* c, pb::ControlReply* r) {
    return impl_->stub->LoadScene(c, request, r);
  });
}

ControlResult Client::LoadSceneText(const std::string& json_text, const std::string& solver) {
  pb::LoadSceneRequest request;
  request.set_json_text(json_text);
  request.set_solver(solver);
  return impl_->Control([&](grpc::ClientContext* c, pb::ControlReply* r) {
    return impl_->stub->LoadScene(c, request, r);
  });
}

SceneList Client::ListScenes() {
  pb::ListScenesReply reply;
  impl_->Invoke(impl_->options.query_deadline, [&](grpc::ClientContext* c) {
    return impl_->stub->ListScenes(c, pb::ListScenesRequest(), &reply);
  });
  SceneList out;
  out.current = reply.current();
  for (const pb::SceneInfo& s : reply.scenes()) {
    out.scenes.push_back({s.name(), s.description(), s.particles(), s.solver()});
  }
  return out;
}

SceneDescription Client::GetScene() {
  pb::SceneDescription reply;
  impl_->Invoke(impl_->options.query_deadline, [&](grpc::ClientContext* c) {
    return impl_->stub->GetScene(c, pb::GetSceneRequest(), &reply);
  });
  return FromProto(reply);
}

std::unique_ptr<FrameStream> Client::StreamFrames(const StreamOptions& options) {
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
  request.set_velocity_encoding(options.velocity_encoding == codec::VelocityEncoding::kOctahedral
                                    ? pb::VELOCITY_ENCODING_OCTAHEDRAL
                                    : pb::VELOCITY_ENCODING_COMPONENTS);

  auto impl = std::make_unique<FrameStream::Impl>();
  impl->options = impl_->options;
  PrepareContext(impl->context, impl_->options);
  // No deadline: a stream lasts as long as the caller wants; Cancel() ends it.
  impl->reader = impl_->stub->StreamFrames(&impl->context, request);
  return std::make_unique<FrameStream>(std::move(impl));
}

}  // namespace dysa::remote
