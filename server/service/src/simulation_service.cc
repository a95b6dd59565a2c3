#include "simulation_service.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>

#include "frame_stream_reactor.h"
#include "proto_conversions.h"
#include "rpc_status.h"

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

namespace {

// RFC 6750 section 2.1: credentials = "Bearer" 1*SP b64token, the scheme case-insensitive
// (RFC 9110 section 11.1). The token as given, or nullopt when the scheme is another.
std::optional<std::string_view> BearerToken(std::string_view credentials) {
  constexpr std::string_view kScheme = "bearer";
  if (credentials.size() <= kScheme.size() || credentials[kScheme.size()] != ' ') {
    return std::nullopt;
  }
  for (size_t i = 0; i < kScheme.size(); ++i) {
    if (std::tolower(static_cast<unsigned char>(credentials[i])) != kScheme[i]) {
      return std::nullopt;
    }
  }
  const std::string_view rest = credentials.substr(kScheme.size());
  return rest.substr(std::min(rest.find_first_not_of(' '), rest.size()));
}

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
  const std::optional<std::string_view> given =
      BearerToken(std::string_view(it->second.data(), it->second.size()));
  if (!given) {
    return {grpc::StatusCode::UNAUTHENTICATED,
            "the authorization metadata must be 'Bearer <token>'"};
  }
  const std::string& expected = access_.token;
  // Compare in time independent of where the first difference is.
  unsigned diff = given->size() != expected.size();
  for (size_t i = 0; i < std::min(given->size(), expected.size()); ++i) {
    diff |= unsigned((*given)[i] ^ expected[i]);
  }
  if (diff != 0) return {grpc::StatusCode::UNAUTHENTICATED, "wrong token"};
  return grpc::Status::OK;
}

template <class Body>
grpc::ServerUnaryReactor* SimulationService::Unary(grpc::CallbackServerContext* context,
                                                   Access access, Body&& body) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  const std::optional<grpc::Status> status = Guarded([&]() -> std::optional<grpc::Status> {
    if (grpc::Status s = CheckAccess(context, access); !s.ok()) return s;
    return body(reactor);
  });
  if (status) reactor->Finish(BoundedStatus(*status));
  return reactor;
}

grpc::ServerUnaryReactor* SimulationService::SubmitControl(grpc::CallbackServerContext* context,
                                                           Control control,
                                                           v1::ControlReply* reply) {
  return Unary(context, Access::kControl,
               [&](grpc::ServerUnaryReactor* reactor) -> std::optional<grpc::Status> {
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
                 return std::nullopt;  // the control finishes the call once applied
               });
}

grpc::ServerUnaryReactor* SimulationService::GetStatus(grpc::CallbackServerContext* context,
                                                       const v1::GetStatusRequest*,
                                                       v1::Status* reply) {
  return Unary(context, Access::kWatch, [&](grpc::ServerUnaryReactor*) {
    ToProto(host_.Status(), *reply);
    return std::optional(grpc::Status::OK);
  });
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
  return Unary(context, Access::kWatch, [&](grpc::ServerUnaryReactor*) {
    ToProto(host_.CurrentParams(), *reply->mutable_params());
    return std::optional(grpc::Status::OK);
  });
}

grpc::ServerUnaryReactor* SimulationService::UpdateParams(grpc::CallbackServerContext* context,
                                                          const v1::UpdateParamsRequest* request,
                                                          v1::UpdateParamsReply* reply) {
  return Unary(context, Access::kControl,
               [&](grpc::ServerUnaryReactor* reactor) -> std::optional<grpc::Status> {
                 UpdateParamsControl control;
                 if (grpc::Status s = ToControl(*request, control); !s.ok()) return s;
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
                 return std::nullopt;
               });
}

grpc::ServerUnaryReactor* SimulationService::LoadScene(grpc::CallbackServerContext* context,
                                                       const v1::LoadSceneRequest* request,
                                                       v1::ControlReply* reply) {
  return Unary(context, Access::kControl,
               [&](grpc::ServerUnaryReactor* reactor) -> std::optional<grpc::Status> {
                 LoadSceneControl control;
                 if (grpc::Status s = ToControl(*request, control); !s.ok()) return s;
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
                 return std::nullopt;
               });
}

grpc::ServerUnaryReactor* SimulationService::ListScenes(grpc::CallbackServerContext* context,
                                                        const v1::ListScenesRequest*,
                                                        v1::ListScenesReply* reply) {
  return Unary(context, Access::kWatch, [&](grpc::ServerUnaryReactor*) {
    for (const BuiltinSceneText& builtin : BuiltinSceneTexts()) {
      ToProto(builtin, *reply->add_scenes());
    }
    reply->set_current(host_.Status().scene);
    return std::optional(grpc::Status::OK);
  });
}

grpc::ServerUnaryReactor* SimulationService::GetScene(grpc::CallbackServerContext* context,
                                                      const v1::GetSceneRequest*,
                                                      v1::SceneDescription* reply) {
  return Unary(context, Access::kWatch, [&](grpc::ServerUnaryReactor*) {
    ToProto(host_.CurrentScene(), *reply);
    return std::optional(grpc::Status::OK);
  });
}

grpc::ServerUnaryReactor* SimulationService::SetStreamView(grpc::CallbackServerContext* context,
                                                           const v1::SetStreamViewRequest* request,
                                                           v1::SetStreamViewReply*) {
  // Steering one's own view is watching: the token StreamFrames needs, no more.
  return Unary(context, Access::kWatch, [&](grpc::ServerUnaryReactor*) {
    try {
      host_.hub().SetStreamView(request->stream_id(), ToView(*request));
    } catch (const std::out_of_range& e) {
      return std::optional(grpc::Status(grpc::StatusCode::NOT_FOUND, e.what()));
    } catch (const std::invalid_argument& e) {
      return std::optional(grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, e.what()));
    }
    return std::optional(grpc::Status::OK);
  });
}

grpc::ServerWriteReactor<grpc::ByteBuffer>* SimulationService::StreamFrames(
    grpc::CallbackServerContext* context, const grpc::ByteBuffer* request) {
  auto* stream = new FrameStreamReactor(host_.hub(), write_starter_);  // deleted in OnDone
  const std::optional<grpc::Status> status = Guarded([&]() -> std::optional<grpc::Status> {
    if (grpc::Status s = CheckAccess(context, Access::kWatch); !s.ok()) return s;
    SubscriptionOptions options;
    if (grpc::Status s = ToOptions(*request, options); !s.ok()) return s;
    stream->Begin(options);
    return std::nullopt;  // the stream finishes itself
  });
  if (status) stream->FinishNow(BoundedStatus(*status));
  return stream;
}

grpc::ServerUnaryReactor* SimulationService::AckFrames(grpc::CallbackServerContext* context,
                                                       const v1::AckFramesRequest* request,
                                                       v1::AckFramesReply*) {
  return Unary(context, Access::kWatch, [&](grpc::ServerUnaryReactor*) {
    if (request->ack_token() == 0) {
      return std::optional(grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                                        "ack_token: allowed range [1, 2^64 - 1] (the stream's)"));
    }
    if (!host_.hub().Acknowledge(request->ack_token(), SteadySeconds(), request->frames(),
                                 1e-6 * request->rtt_us())) {
      return std::optional(
          grpc::Status(grpc::StatusCode::NOT_FOUND, "ack_token: no stream has this token"));
    }
    return std::optional(grpc::Status::OK);
  });
}

}  // namespace dysa::service
