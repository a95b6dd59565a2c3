#include "dysa/service/server.h"

#include <grpcpp/grpcpp.h>

#include <algorithm>
#include <chrono>
#include <stdexcept>

#include "simulation_service.h"

namespace dysa::service {

Server::Server(SimulationHost& host, const ServerOptions& options) : host_(host) {
  service_ =
      std::make_unique<SimulationService>(host, AccessPolicy{options.token, options.protect_watch});
  std::shared_ptr<grpc::ServerCredentials> credentials;
  if (!options.tls_cert_pem.empty() || !options.tls_key_pem.empty()) {
    grpc::SslServerCredentialsOptions ssl;
    ssl.pem_key_cert_pairs.push_back({options.tls_key_pem, options.tls_cert_pem});
    credentials = grpc::SslServerCredentials(ssl);
  } else {
    credentials = grpc::InsecureServerCredentials();
  }
  grpc::ServerBuilder builder;
  builder.AddListeningPort(options.listen, credentials, &port_);
  builder.RegisterService(service_.get());
  builder.SetMaxReceiveMessageSize(options.max_receive_bytes);
  server_ = builder.BuildAndStart();
  if (!server_ || port_ == 0) {
    throw std::runtime_error("cannot listen on " + options.listen +
                             " (address in use, not local, or malformed ADDR:PORT)");
  }
  host_.Start();
}

Server::~Server() { Shutdown(); }

bool Server::Shutdown(std::chrono::steady_clock::time_point deadline) {
  if (shut_down_) return stopped_;
  shut_down_ = true;
  host_.hub().Close();
  // Control calls in flight are answered by the host as it stops (or right away, if queued):
  // gRPC's shutdown waits for every call to finish, so the thread goes first.
  stopped_ = host_.StopWithin(deadline);
  if (!stopped_) return false;
  const auto left = deadline - std::chrono::steady_clock::now();
  server_->Shutdown(std::chrono::system_clock::now() +
                    std::chrono::duration_cast<std::chrono::system_clock::duration>(
                        std::max(left, std::chrono::steady_clock::duration::zero())));
  server_->Wait();
  return true;
}

}  // namespace dysa::service
