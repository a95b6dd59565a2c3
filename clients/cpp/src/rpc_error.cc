#include "rpc_error.h"

#include <array>
#include <sstream>
#include <string>
#include <utility>

namespace dysa::remote {

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

}  // namespace dysa::remote
