// From a failed call's grpc::Status to the RpcError it throws. Internal to dysa_client.
#pragma once

#include <grpcpp/grpcpp.h>

#include <chrono>

#include "dysa/client/client.h"

namespace dysa::remote {

// The error a failed call throws. Adds what the bare gRPC message leaves out: which server
// could not be reached, and how to pass a token. `deadline`: the call's, named in a
// DEADLINE_EXCEEDED message; 0 for none.
RpcError ToError(const grpc::Status& status, const ConnectOptions& options,
                 std::chrono::milliseconds deadline);

}  // namespace dysa::remote
