// The gRPC adapter of dysa.v1.Simulation (callback API): checks credentials, converts requests
// into SimulationHost controls and hub subscriptions, and results back into replies
// (proto_conversions.h); StreamFrames hands its call to a FrameStreamReactor
// (frame_stream_reactor.h). No simulation logic lives here.
#pragma once

#include <string>

#include "dysa/service/simulation_host.h"
#include "dysa/service/write_starter.h"
#include "dysa/v1/simulation.grpc.pb.h"

namespace dysa::service {

struct AccessPolicy {
  std::string token;           // empty: no token needed
  bool protect_watch = false;  // the token is needed for reading RPCs and streams too
};

// StreamFrames is a raw method: frames go out as messages serialised once per encoded frame and
// shared by every subscriber of its stream configuration (a reference-counted slice each), so
// a subscriber costs the server no copy and no serialisation of its own.
class SimulationService final
    : public v1::Simulation::WithRawCallbackMethod_StreamFrames<v1::Simulation::CallbackService> {
 public:
  // Installs the hub's transport builder: call before the host starts publishing.
  SimulationService(SimulationHost& host, AccessPolicy access);

  grpc::ServerUnaryReactor* GetStatus(grpc::CallbackServerContext* context,
                                      const v1::GetStatusRequest* request,
                                      v1::Status* reply) override;
  grpc::ServerUnaryReactor* Pause(grpc::CallbackServerContext* context,
                                  const v1::PauseRequest* request,
                                  v1::ControlReply* reply) override;
  grpc::ServerUnaryReactor* Resume(grpc::CallbackServerContext* context,
                                   const v1::ResumeRequest* request,
                                   v1::ControlReply* reply) override;
  grpc::ServerUnaryReactor* Step(grpc::CallbackServerContext* context,
                                 const v1::StepRequest* request, v1::ControlReply* reply) override;
  grpc::ServerUnaryReactor* StepBack(grpc::CallbackServerContext* context,
                                     const v1::StepBackRequest* request,
                                     v1::ControlReply* reply) override;
  grpc::ServerUnaryReactor* Reset(grpc::CallbackServerContext* context,
                                  const v1::ResetRequest* request,
                                  v1::ControlReply* reply) override;
  grpc::ServerUnaryReactor* GetParams(grpc::CallbackServerContext* context,
                                      const v1::GetParamsRequest* request,
                                      v1::ParamsReply* reply) override;
  grpc::ServerUnaryReactor* UpdateParams(grpc::CallbackServerContext* context,
                                         const v1::UpdateParamsRequest* request,
                                         v1::UpdateParamsReply* reply) override;
  grpc::ServerUnaryReactor* LoadScene(grpc::CallbackServerContext* context,
                                      const v1::LoadSceneRequest* request,
                                      v1::ControlReply* reply) override;
  grpc::ServerUnaryReactor* ListScenes(grpc::CallbackServerContext* context,
                                       const v1::ListScenesRequest* request,
                                       v1::ListScenesReply* reply) override;
  grpc::ServerUnaryReactor* GetScene(grpc::CallbackServerContext* context,
                                     const v1::GetSceneRequest* request,
                                     v1::SceneDescription* reply) override;
  grpc::ServerUnaryReactor* SetStreamView(grpc::CallbackServerContext* context,
                                          const v1::SetStreamViewRequest* request,
                                          v1::SetStreamViewReply* reply) override;
  grpc::ServerWriteReactor<grpc::ByteBuffer>* StreamFrames(
      grpc::CallbackServerContext* context, const grpc::ByteBuffer* request) override;
  grpc::ServerUnaryReactor* AckFrames(grpc::CallbackServerContext* context,
                                      const v1::AckFramesRequest* request,
                                      v1::AckFramesReply* reply) override;

 private:
  enum class Access { kWatch, kControl };
  // OK, or UNAUTHENTICATED when the call lacks the token the policy asks for ('authorization:
  // Bearer <token>', the scheme in any case).
  grpc::Status CheckAccess(const grpc::CallbackServerContext* context, Access access) const;
  // A unary call: checks access, then runs `body(reactor)`, which returns the status to finish
  // the call with, or nullopt when it queued a control that finishes it. An exception from the
  // body finishes the call as Guarded (rpc_status.h) says; every message is bounded.
  template <class Body>
  grpc::ServerUnaryReactor* Unary(grpc::CallbackServerContext* context, Access access, Body&& body);
  // Queues a control; the reply is filled and the call finished once it is applied.
  grpc::ServerUnaryReactor* SubmitControl(grpc::CallbackServerContext* context, Control control,
                                          v1::ControlReply* reply);

  SimulationHost& host_;
  const AccessPolicy access_;
  WriteStarter write_starter_;  // every stream's first write of a frame
};

}  // namespace dysa::service
