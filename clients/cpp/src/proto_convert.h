// Conversions between the generated dysa.v1 types and the plain structs of dysa/client/types.h,
// all in one place. Internal to dysa_client.
#pragma once

#include <vector>

#include "dysa/client/types.h"
#include "dysa/v1/simulation.pb.h"

namespace dysa::remote {

namespace pb = ::dysa::v1;

ServerStatus FromProto(const pb::Status& s);
ControlResult FromProto(const pb::ControlReply& r);
std::vector<ParamInfo> FromProto(const google::protobuf::RepeatedPtrField<pb::ParamInfo>& ps);
SceneList FromProto(const pb::ListScenesReply& r);
SceneDescription FromProto(const pb::SceneDescription& s);
// Into `out`, whose chunk buffers are reused.
void FromProto(const pb::FrameMessage& m, FrameMessage& out);

pb::StreamFramesRequest ToProto(const StreamOptions& options);

}  // namespace dysa::remote
