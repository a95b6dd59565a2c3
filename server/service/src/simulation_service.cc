#include "simulation_service.h"

#include <algorithm>
#include <chrono>
#include <string>
#include <string_view>
#include <utility>

#include "frame_stream_reactor.h"
#include "proto_conversions.h"

namespace dysa::service {
namespace {

// The call as the simulation thread sees it: when its caller stops waiting, and whether it has
// gone. The context lives until the call is finished, which only the control's answer does.
ControlCaller CallerOf(grpc::CallbackServerContext* context) {
  ControlCaller caller;
  const auto left = context->deadline() - std::chrono::system_clock::now();
  // No deadline reads as the far future (system_clock's max): never.
  if (left < std::chrono::hours(24 * 365)) {
    caller.deadline = std::chrono::steady_clock::now() +
                      std::chrono::duration_cast<std::chrono::steady_clock::duration>(left);
  }
  caller.cancelled = [context] { return context->IsCancelled(); };
  return caller;
}

}  // namespace

SimulationService::SimulationService(SimulationHost& host, AccessPolicy access)
    : host_(host), access_(std::move(access)) {
  host_.hub().set_transport_builder(BuildWireFrame);
}

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
  host_.Submit(
      std::move(control),
      [reactor, reply](ControlResult r) {
        if (r.code == ControlCode::kOk) {
          ToProto(r.status, *reply->mutable_status());
          reply->set_reset(r.reset);
          reply->set_frames_moved(r.frames_moved);
        }
        reactor->Finish(ToGrpc(r.code, r.message));
      },
      CallerOf(context));
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
  UpdateParamsControl control;
  if (grpc::Status s = ToControl(*request, control); !s.ok()) {
    reactor->Finish(s);
    return reactor;
  }
  host_.Submit(
      std::move(control),
      [reactor, reply](ControlResult r) {
        if (r.code == ControlCode::kOk) {
          reply->set_reset(r.reset);
          ToProto(r.params, *reply->mutable_params());
          ToProto(r.status, *reply->mutable_status());
        }
        reactor->Finish(ToGrpc(r.code, r.message));
      },
      CallerOf(context));
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
  LoadSceneControl control;
  if (grpc::Status s = ToControl(*request, control); !s.ok()) {
    reactor->Finish(s);
    return reactor;
  }
  host_.Submit(
      std::move(control),
      [reactor, reply](ControlResult r) {
        if (r.code == ControlCode::kOk) {
          ToProto(r.status, *reply->mutable_status());
          reply->set_reset(true);
        }
        reactor->Finish(ToGrpc(r.code, r.message));
      },
      CallerOf(context));
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
    ToProto(builtin, *reply->add_scenes());
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

grpc::ServerWriteReactor<grpc::ByteBuffer>* SimulationService::StreamFrames(
    grpc::CallbackServerContext* context, const grpc::ByteBuffer* request) {
  auto* stream = new FrameStreamReactor(host_.hub(), write_starter_);  // deleted in OnDone
  if (grpc::Status s = CheckAccess(context, Access::kWatch); !s.ok()) {
    stream->FinishNow(s);
    return stream;
  }
  SubscriptionOptions options;
  if (grpc::Status s = ToOptions(*request, options); !s.ok()) {
    stream->FinishNow(s);
    return stream;
  }
  stream->Begin(options);
  return stream;
}

}  // namespace dysa::service
