#include "dysa/client/client.h"

#include <grpcpp/grpcpp.h>

#include <atomic>
#include <fstream>
#include <functional>
#include <sstream>

#include "dysa/v1/simulation.grpc.pb.h"
#include "frame_acknowledger.h"
#include "proto_convert.h"
#include "rpc_error.h"

namespace dysa::remote {
namespace {

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

void PrepareContext(grpc::ClientContext& context, const ConnectOptions& options) {
  if (!options.token.empty()) context.AddMetadata("authorization", "Bearer " + options.token);
}

}  // namespace

// ---------------------------------------------------------------------------------------------

struct FrameStream::Impl {
  ConnectOptions options;
  grpc::ClientContext context;
  std::unique_ptr<grpc::ClientReader<pb::FrameMessage>> reader;
  pb::FrameMessage message;
  std::atomic<bool> cancelled{false};
  bool finished = false;
  std::unique_ptr<FrameAcknowledger> acks;  // with a budget: the delivery signal
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
  if (impl_->acks && impl_->message.last_of_frame()) impl_->acks->FrameReceived();
  FromProto(impl_->message, out);
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
  std::shared_ptr<grpc::Channel> channel;
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
  impl_->channel = grpc::CreateCustomChannel(options.address, Credentials(options), args);
  impl_->stub = pb::Simulation::NewStub(impl_->channel);
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

void Client::SetStreamView(uint64_t stream_id, const StreamCamera& camera) {
  pb::SetStreamViewRequest request;
  request.set_stream_id(stream_id);
  const auto vec = [](const std::array<double, 3>& v, pb::Vec3* out) {
    out->set_x(v[0]);
    out->set_y(v[1]);
    out->set_z(v[2]);
  };
  vec(camera.eye, request.mutable_eye());
  vec(camera.target, request.mutable_target());
  vec(camera.up, request.mutable_up());
  request.set_fov_y_deg(camera.fov_y_deg);
  request.set_aspect(camera.aspect);
  pb::SetStreamViewReply reply;
  impl_->Invoke(impl_->options.query_deadline, [&](grpc::ClientContext* c) {
    return impl_->stub->SetStreamView(c, request, &reply);
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
  return FromProto(reply);
}

SceneDescription Client::GetScene() {
  pb::SceneDescription reply;
  impl_->Invoke(impl_->options.query_deadline, [&](grpc::ClientContext* c) {
    return impl_->stub->GetScene(c, pb::GetSceneRequest(), &reply);
  });
  return FromProto(reply);
}

std::unique_ptr<FrameStream> Client::StreamFrames(const StreamOptions& options) {
  pb::StreamFramesRequest request = ToProto(options);
  auto impl = std::make_unique<FrameStream::Impl>();
  impl->options = impl_->options;
  const bool budget =
      options.fps_target > 0 || options.byte_budget > 0 || options.particle_budget > 0;
  if (options.acknowledge && budget) {
    request.set_ack_token(FrameAcknowledger::NewToken());
    impl->acks = std::make_unique<FrameAcknowledger>(
        impl_->channel, request.ack_token(),
        impl_->options.token.empty() ? "" : "Bearer " + impl_->options.token);
  }
  PrepareContext(impl->context, impl_->options);
  // No deadline: a stream lasts as long as the caller wants; Cancel() ends it.
  impl->reader = impl_->stub->StreamFrames(&impl->context, request);
  return std::make_unique<FrameStream>(std::move(impl));
}

}  // namespace dysa::remote
