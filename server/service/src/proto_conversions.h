// Conversions between the wire types (dysa.v1 messages, gRPC status) and the server's own (core
// scenes and parameters, SimulationHost controls and results, hub subscriptions): the one place
// where generated code meets domain types (DESIGN.md, "Layers"). A request that does not convert
// gives INVALID_ARGUMENT naming the field, and nothing of it is applied.
#pragma once

#include <grpcpp/support/byte_buffer.h>
#include <grpcpp/support/status.h>

#include <string>

#include "dysa/core/params.h"
#include "dysa/core/scene.h"
#include "dysa/core/types.h"
#include "dysa/service/frame_hub.h"
#include "dysa/service/simulation_host.h"
#include "dysa/v1/simulation.pb.h"

namespace dysa::service {

// Core and host types to replies.
grpc::Status ToGrpc(ControlCode code, const std::string& message);
void ToProto(const HostStatus& s, v1::Status& out);
void ToProto(const Vec3d& v, v1::Vec3& out);
void ToProto(const ObstacleMotion& motion, v1::ObstacleMotion& out);
void ToProto(const HostScene& s, v1::SceneDescription& out);
void ToProto(const Params& params, google::protobuf::RepeatedPtrField<v1::ParamInfo>& out);
// A built-in scene as ListScenes lists it, with its particle count at its own parameters.
void ToProto(const BuiltinSceneText& builtin, v1::SceneInfo& out);

// Requests to controls and subscriptions.
// The values to set, in name order: all of params.values, or those the update mask names.
grpc::Status ToControl(const v1::UpdateParamsRequest& request, UpdateParamsControl& control);
// The scene to load, parsed and validated here, off the simulation thread.
grpc::Status ToControl(const v1::LoadSceneRequest& request, LoadSceneControl& control);
// Codec stream settings from a serialised StreamFramesRequest (StreamFrames is a raw method);
// zero means the default.
grpc::Status ToOptions(const grpc::ByteBuffer& request, SubscriptionOptions& options);
// A camera, defaults filled in (the range checks are StreamView::Validate's).
StreamView ToView(const v1::SetStreamViewRequest& request);

}  // namespace dysa::service
