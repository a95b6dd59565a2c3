// The statuses the gRPC adapter answers with: bounded, escaped, and never an exception.
//
// A status message travels in the call's trailing metadata, percent-encoded (a byte outside
// printable ASCII takes 3), and a client refuses metadata over 8 KiB by default: a message that
// quotes a 4 MB field name would reach the caller as a metadata-size error instead of the
// message. And gRPC answers an exception escaping a handler with UNIMPLEMENTED and no message.
#pragma once

#include <grpcpp/support/status.h>

#include <cstddef>
#include <exception>
#include <new>
#include <optional>
#include <string>
#include <string_view>

#include "dysa/core/types.h"

namespace dysa::service {

// At most 3 x 2 KiB percent-encoded: under the 8 KiB of metadata a client accepts.
inline constexpr size_t kMaxStatusMessageBytes = 2048;

// A status whose message is at most kMaxStatusMessageBytes, control characters escaped
// (SafeText; messages quote client text already escaped and bounded, which passes unchanged).
grpc::Status BoundedStatus(grpc::StatusCode code, std::string_view message);
grpc::Status BoundedStatus(const grpc::Status& status);

// Runs `body` (returning std::optional<grpc::Status>: the status to finish the call with, or
// nullopt when something else finishes it) and turns an exception it throws into a status: a
// ConfigError is the caller's mistake (INVALID_ARGUMENT, naming the field), any other the
// server's (INTERNAL, with what it says).
template <class Body>
std::optional<grpc::Status> Guarded(Body&& body) noexcept {
  try {
    return body();
  } catch (const ConfigError& e) {
    return BoundedStatus(grpc::StatusCode::INVALID_ARGUMENT, e.what());
  } catch (const std::bad_alloc&) {
    return BoundedStatus(grpc::StatusCode::INTERNAL, "internal error: out of memory");
  } catch (const std::exception& e) {
    return BoundedStatus(grpc::StatusCode::INTERNAL, std::string("internal error: ") + e.what());
  } catch (...) {
    return BoundedStatus(grpc::StatusCode::INTERNAL, "internal error: an unknown exception");
  }
}

}  // namespace dysa::service
