#include "rpc_status.h"

#include "dysa/core/text.h"

namespace dysa::service {

grpc::Status BoundedStatus(grpc::StatusCode code, std::string_view message) {
  return {code, SafeText(message, kMaxStatusMessageBytes)};
}

grpc::Status BoundedStatus(const grpc::Status& status) {
  if (status.ok()) return status;
  return BoundedStatus(status.error_code(), status.error_message());
}

}  // namespace dysa::service
